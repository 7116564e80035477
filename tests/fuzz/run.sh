#!/bin/sh
# Runs libFuzzer targets: each first replays its committed corpus once (a
# regression test: every input that once mattered must still pass), then
# fuzzes for SECONDS from that corpus, keeping what it finds in WORK/<target>
# so later runs start further on.  Prints one line per target with the
# number of executions; exits 1 if any target crashed, leaked, hung or ran
# out of memory (the reproducer is left in WORK/crash-<target>-*).
#
#   sh tests/fuzz/run.sh BINDIR WORK SECONDS TARGET...
#
# FUZZ_JOBS targets run at once (default: the number of CPUs; libFuzzer
# runs one process on one core); each one's lines are printed whole, in
# the order given, once all have finished.
set -u
if [ "${1:-}" != --one ]; then
	[ $# -ge 3 ] || { echo "usage: sh tests/fuzz/run.sh BINDIR WORK SECONDS TARGET..." >&2; exit 2; }
	bindir=$1
	work=$2
	secs=$3
	shift 3
	mkdir -p "$work"
	for t in "$@"; do
		rm -f "$work/$t.out" "$work/$t.rc"
		printf '%s\n' "$t"
	done | xargs -P "${FUZZ_JOBS:-$(nproc 2>/dev/null || echo 1)}" -L 1 \
	    sh "$0" --one "$bindir" "$work" "$secs"
	fail=0
	for t in "$@"; do
		cat "$work/$t.out" 2>/dev/null
		[ "$(cat "$work/$t.rc" 2>/dev/null)" = 0 ] || fail=1
	done
	exit $fail
fi

# --one BINDIR WORK SECONDS TARGET: one target, its lines to WORK/TARGET.out
# and its status to WORK/TARGET.rc.
bindir=$2
work=$3
secs=$4
t=$5
exec >"$work/$t.out" 2>&1
fail=0
# One allocation may be as large as the library allows an image to be
# (common/image.c: 2^28 pixels of float RGB, 3 GiB): a header that claims
# that much is refused later, when its data is missing, and is not a bug.
# What the process holds (RSS) is limited to 2 GiB all the same.
mlimit=3200
fuzz_one() {
	bin=$bindir/fuzz_$t
	corpus=tests/fuzz/corpus/$t
	dict=
	[ -f tests/fuzz/$t.dict ] && dict=-dict=tests/fuzz/$t.dict
	mkdir -p "$work/$t"
	if ! "$bin" -runs=0 -rss_limit_mb=2048 -malloc_limit_mb=$mlimit \
	    -timeout=20 "$corpus" \
	    >"$work/$t.replay.log" 2>&1; then
		echo "fuzz $t: corpus replay FAILED (see $work/$t.replay.log)"
		tail -30 "$work/$t.replay.log"
		fail=1
		return
	fi
	[ "$secs" -gt 0 ] || { echo "fuzz $t: corpus of $(ls "$corpus" | wc -l) replayed"; return; }
	# shellcheck disable=SC2086
	if "$bin" $dict -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 \
	    -malloc_limit_mb=$mlimit -max_len=65536 -print_final_stats=1 \
	    -artifact_prefix="$work/crash-$t-" "$work/$t" "$corpus" \
	    >"$work/$t.log" 2>&1; then
		runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t.log")
		echo "fuzz $t: corpus replayed, then ${runs:-?} executions in ${secs} s, no crash"
	else
		echo "fuzz $t: FAILED (see $work/$t.log)"
		grep -E 'ERROR|SUMMARY|Test unit written|==[0-9]+==' "$work/$t.log" | head -20
		fail=1
	fi
}
fuzz_one
echo $fail >"$work/$t.rc"
exit 0
