#!/bin/sh
# Runs each unit-test binary (cmocka) and prints one closing line:
# "unit: N passed, N failed".
#
# The binaries run UNIT_JOBS at a time (default: the number of CPUs): most
# are single-threaded Monte Carlo checks, and one at a time left a core of
# CI's two idle for minutes (the AddressSanitizer pass alone is ~6 minutes
# of them).  They share nothing on disk (tests/unit/tmpdir.c gives each its
# own directory).  Each one's output is kept and printed whole, in the
# order given, once all have finished, so logs never interleave.
jobs=${UNIT_JOBS:-$(nproc 2>/dev/null || echo 1)}
dir=$(mktemp -d "${TMPDIR:-/tmp}/pm-unit-XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT INT TERM

i=0
for t in "$@"; do
	i=$((i + 1))
	printf '%d %s\n' "$i" "$t"
done | xargs -P "$jobs" -L 1 sh -c \
    '"$2" >"$0/$1.log" 2>&1; echo $? >"$0/$1.rc"' "$dir"

pass=0
fail=0
i=0
for t in "$@"; do
	i=$((i + 1))
	cat "$dir/$i.log" 2>/dev/null
	if [ "$(cat "$dir/$i.rc" 2>/dev/null)" = 0 ]; then
		pass=$((pass + 1))
	else
		echo "FAILED: $t"
		fail=$((fail + 1))
	fi
done
echo "unit: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
