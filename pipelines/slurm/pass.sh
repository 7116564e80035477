#!/bin/sh
# pipelines/slurm/pass.sh: task I of the pass array, progressive pass I,
# as pipelines/progressive.mk makes it: its own photons (seed SEED + I),
# balanced and rendered with pass I's radii, into passes/pass-III.exr; the
# pass's map is deleted once rendered.  Keeps a valid image already there.
# Run by sbatch in the render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
i=$(pm_task) || exit 1
map=$(printf 'passes/pass-%03d.pmap' "$i")
out=$(printf 'passes/pass-%03d.exr' "$i")
trap 'pm_clean "$map.shot" "$map" "$out"; rm -f "$map.shot" "$map"; pm_log "pass: cancelled, $out not written"; exit 143' TERM INT
pm_log "pass: $i of $PASSES on $(hostname), job ${SLURM_JOB_ID:-local}"
if pm_exr_ok "$out"; then
	pm_log "pass: kept $out (reads back)"
	exit 0
fi
pm_clean "$map.shot" "$map" "$out"
s=$((SEED + i))
# RENDER is a list of options, split into words on purpose; no -t, since
# maps and images record the command line and the default thread count
# already follows the allocation.
# shellcheck disable=SC2086
pm_run pm-shoot -v -f --seed "$s" --photons "$PHOTONS" --caustic-photons "$CAUSTIC" \
    -o "$map.shot" "$SCENE" &&
    pm_run pm-balance -v -f --pass "$i" --alpha "$ALPHA" -o "$map" "$map.shot" &&
    pm_run pm-render -v -f --pass "$i" --seed "$s" --alpha "$ALPHA" --spp "$SPP" \
	--size "$SIZE" $RENDER -o "$out" "$SCENE" "$map"
r=$?
pm_clean "$map.shot" "$map" "$out"
rm -f "$map.shot" "$map"
[ $r -eq 0 ] && pm_log "pass: wrote $out"
exit $r
