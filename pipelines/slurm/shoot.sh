#!/bin/sh
# pipelines/slurm/shoot.sh: task I of the shoot array, one photon shard.
# Shoots shard I's range of photon paths (pm_shard in lib.sh) into
# shards/shard-III.pmap, unless a valid one is already there.  Run by
# sbatch in the render's directory (see submit), or by submit --local.
cd "${PM_DIR:-.}" && . ./render.conf && . "$PIPE/lib.sh" || exit 1
PATH=$BIN:$PATH
i=$(pm_task) || exit 1
out=$(printf 'shards/shard-%03d.pmap' "$i")
trap 'pm_clean "$out"; pm_log "shoot: cancelled, $out not written"; exit 143' TERM INT
pm_log "shoot: shard $i of $SHARDS on $(hostname), job ${SLURM_JOB_ID:-local}"
if pm_shard_ok "$out" "$i"; then
	pm_log "shoot: kept $out (reads back, shard $i of this render)"
	exit 0
fi
pm_clean "$out"
pm_shard "$i"
pm_run pm-shoot -v -f --seed "$SEED" --photons "$global" --caustic-photons "$caustic" \
    --first-index "$first" -o "$out" "$SCENE" || { pm_clean "$out"; exit 1; }
pm_log "shoot: wrote $out"
