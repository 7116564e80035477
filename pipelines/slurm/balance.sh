#!/bin/sh
# pipelines/slurm/balance.sh: the balance job.  Merges every shard into
# scene.pmap with pm-balance, unless a valid scene.pmap is already there;
# refuses (exit 1, saying which) when a shard is missing or invalid.  Run by
# sbatch in the render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
out=scene.pmap
trap 'pm_clean "$out"; pm_log "balance: cancelled, $out not written"; exit 143' TERM INT
pm_log "balance: $SHARDS shards on $(hostname), job ${SLURM_JOB_ID:-local}"
if pm_map_ok "$out"; then
	pm_log "balance: kept $out (passes pm-inspect --verify)"
	exit 0
fi
set --
bad=0
i=1
while [ "$i" -le "$SHARDS" ]; do
	f=$(printf 'shards/shard-%03d.pmap' "$i")
	if ! pm_shard_ok "$f" "$i"; then
		pm_log "balance: $f is missing or invalid (see logs/shoot-*_$i.out)"
		bad=1
	fi
	set -- "$@" "$f"
	i=$((i + 1))
done
[ $bad -eq 0 ] || { pm_log "balance: not run"; exit 1; }
pm_clean "$out"
# BALANCE is a list of options, split into words on purpose.
# shellcheck disable=SC2086
pm_run pm-balance -v -f $BALANCE -o "$out" "$@" || { pm_clean "$out"; exit 1; }
pm_log "balance: wrote $out"
