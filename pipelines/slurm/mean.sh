#!/bin/sh
# pipelines/slurm/mean.sh: the final job of a progressive render.  Averages
# every pass (passes/pass-III.exr) into mean.exr and tone-maps it into
# mean.png, keeping what is valid and newer than its inputs; exit 1, saying
# which, when a pass is missing or unreadable.  Run by sbatch in the
# render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
pm_log "final: the mean of $PASSES passes on $(hostname), job ${SLURM_JOB_ID:-local}"
trap 'pm_clean mean.exr mean.png; pm_log "final: cancelled"; exit 143' TERM INT
set --
stale=0
i=1
while [ "$i" -le "$PASSES" ]; do
	f=$(printf 'passes/pass-%03d.exr' "$i")
	if ! pm_exr_ok "$f"; then
		pm_log "final: $f is missing or unreadable (see logs/pass-*_$i.out)"
		exit 1
	fi
	[ "$f" -nt mean.exr ] && stale=1
	set -- "$@" "$f"
	i=$((i + 1))
done
if [ $stale -eq 0 ] && pm_exr_ok mean.exr; then
	pm_log "final: kept mean.exr"
else
	pm_clean mean.exr
	pm_run pm-downsample -f -q -o mean.exr "$@" || exit 1
fi
if pm_png_ok mean.png && [ ! mean.exr -nt mean.png ]; then
	pm_log "final: kept mean.png"
else
	pm_clean mean.png
	pm_run pm-downsample -f -q --factor "$FACTOR" -F "$FILTER" -o mean.png mean.exr || exit 1
fi
pm_log "final: done"
