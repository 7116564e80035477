#!/bin/sh
# pipelines/slurm/final.sh: the final job of a turntable.  Downsamples and
# tone-maps every frame's image (frames/frame-II.exr) into
# frames/frame-II.png, keeping a PNG that is whole and newer than its
# image; exit 1, saying which, when an image is missing or unreadable.
# Run by sbatch in the render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
pm_log "final: $FRAMES frames on $(hostname), job ${SLURM_JOB_ID:-local}"
trap 'pm_clean frames/frame-*.png; pm_log "final: cancelled"; exit 143' TERM INT
s=0
i=1
while [ "$i" -le "$FRAMES" ]; do
	exr=$(printf 'frames/frame-%02d.exr' "$i")
	png=$(printf 'frames/frame-%02d.png' "$i")
	i=$((i + 1))
	if ! pm_exr_ok "$exr"; then
		pm_log "final: $exr is missing or unreadable (see logs/render-*_$((i - 1)).out)"
		s=1
	elif pm_png_ok "$png" && [ ! "$exr" -nt "$png" ]; then
		pm_log "final: kept $png"
	else
		pm_clean "$png"
		pm_run pm-downsample -q -f --factor "$FACTOR" -F "$FILTER" -o "$png" "$exr" || s=1
	fi
done
[ $s -eq 0 ] && pm_log "final: done"
exit $s
