#!/bin/sh
# pipelines/slurm/frame.sh: task I of the render array, turntable frame I.
# Renders camera I (frames/cam-II.txt) from scene.pmap into
# frames/frame-II.exr, unless a valid image is already there.  Run by
# sbatch in the render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
i=$(pm_task) || exit 1
cam=$(printf 'frames/cam-%02d.txt' "$i")
out=$(printf 'frames/frame-%02d.exr' "$i")
trap 'pm_clean "$out"; pm_log "render: cancelled, $out not written"; exit 143' TERM INT
pm_log "render: frame $i of $FRAMES on $(hostname), job ${SLURM_JOB_ID:-local}"
if pm_exr_ok "$out"; then
	pm_log "render: kept $out (reads back)"
	exit 0
fi
pm_clean "$out"
# No -t: an image records pm-render's command line, and the tools'
# default thread count already follows the allocation (the processors the
# task may run on).  RENDER is a list of options, split into words on
# purpose.
# shellcheck disable=SC2086
pm_run pm-render -v -f --spp "$SPP" --size "$SIZE" $RENDER \
    --cameras "$cam" -o "$out" "$SCENE" scene.pmap || { pm_clean "$out"; exit 1; }
pm_log "render: wrote $out"
