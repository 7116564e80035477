# pipelines/slurm/lib.sh: what the submit driver and the job scripts share,
# sourced by both: the shard ranges and the checks that decide whether an
# output is kept.  Expects render.conf's variables (see submit) and the
# tools on PATH.

# pm_part TOTAL N I: paths in part I (1 to N) of TOTAL split into N parts,
# the first TOTAL % N parts one longer.
pm_part() {
	echo $(($1 / $2 + ($3 - 1 < $1 % $2)))
}

# pm_start TOTAL N I: first path of part I, the parts before it summed.
pm_start() {
	_k=$(($3 - 1))
	_r=$(($1 % $2))
	[ $_k -lt $_r ] || _k=$_r
	echo $((($3 - 1) * ($1 / $2) + _k))
}

# pm_shard I: sets first, global and caustic for shard I.  Shard I starts
# at part I of the larger of the two counts, so neither kind's ranges
# overlap; with PHOTONS = CAUSTIC the shards tile [0, PHOTONS) exactly and
# merge into the map of one pm-shoot run.
pm_shard() {
	_m=$PHOTONS
	[ "$CAUSTIC" -le "$_m" ] || _m=$CAUSTIC
	first=$(pm_start $_m $SHARDS $1)
	global=$(pm_part $PHOTONS $SHARDS $1)
	caustic=$(pm_part $CAUSTIC $SHARDS $1)
}

# pm_shard_ok FILE I: FILE reads back (header, counts, crc32) and is shard
# I of this render: same seed, and every map in it starts at shard I's
# first path and emitted its count.
pm_shard_ok() {
	[ -f "$1" ] || return 1
	pm_shard "$2"
	_t=$(pm-inspect -q "$1" 2>/dev/null) || return 1
	echo "$_t" | awk -F'\t' -v s="$SEED" -v f="$first" -v g="$global" -v c="$caustic" '
	    $1 == "seed" { seed = $2 }
	    $1 == "global.first_index" && $2 != f { bad = 1 }
	    $1 == "global.emitted" && $2 != g { bad = 1 }
	    $1 == "caustic.first_index" && $2 != f { bad = 1 }
	    $1 == "caustic.emitted" && $2 != c { bad = 1 }
	    END { exit !(seed == s && !bad) }'
}

# pm_map_ok FILE: FILE passes pm-inspect --verify (crc32, every kd-tree in
# order) and holds this render's seed and photon counts.
pm_map_ok() {
	[ -f "$1" ] || return 1
	_t=$(pm-inspect -q --verify "$1" 2>/dev/null) || return 1
	echo "$_t" | awk -F'\t' -v s="$SEED" -v g="$PHOTONS" -v c="$CAUSTIC" '
	    $1 == "seed" { seed = $2 }
	    $1 == "global.emitted" && $2 != g { bad = 1 }
	    $1 == "caustic.emitted" && $2 != c { bad = 1 }
	    END { exit !(seed == s && !bad) }'
}

# pm_exr_ok FILE: FILE reads back as an OpenEXR image.
pm_exr_ok() {
	[ -f "$1" ] && pm-downsample -q -o - "$1" >/dev/null 2>&1
}

# pm_png_ok FILE: FILE is a whole PNG (signature first, IEND chunk last).
pm_png_ok() {
	[ -f "$1" ] &&
	    [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] &&
	    [ "$(tail -c 12 "$1" | od -An -tx1 | tr -d ' \n')" = 0000000049454e44ae426082 ]
}

# pm_log WORDS: one line on standard output (the job's log), stamped.
pm_log() {
	echo "$(date -u +%H:%M:%S) $*"
}

# pm_run COMMAND...: logs the command, runs it; on failure removes the
# temporaries it may have left beside OUT (path.tmpPID.N, see
# formats/tmpfile.h), logs the status and returns it.
pm_run() {
	pm_log "+ $*"
	"$@"
	_s=$?
	[ $_s -eq 0 ] || pm_log "failed: exit $_s"
	return $_s
}

# pm_clean OUT...: removes what a killed writer of OUT left behind.
pm_clean() {
	for _o in "$@"; do
		for _f in "$_o".tmp*; do
			[ -e "$_f" ] && rm -f "$_f"
		done
	done
	return 0
}

# pm_task: the array task id (SLURM_ARRAY_TASK_ID), or PM_TASK when run
# without Slurm.
pm_task() {
	echo "${SLURM_ARRAY_TASK_ID:-${PM_TASK:?no SLURM_ARRAY_TASK_ID}}"
}
