#!/bin/sh
# run-each.sh NAME JOBS TEST...: runs each test JOBS at a time and prints
# one closing line, "NAME: N passed, N failed"; non-zero exit when any
# failed.  A test ending in .sh runs under sh (the CLI scripts), any other
# is executed (the cmocka binaries).
#
# Why at once: most tests are single-threaded Monte Carlo checks or runs of
# the tools on tiny scenes, and one at a time left one of CI's two cores
# idle for minutes (under AddressSanitizer most of all).  They share
# nothing on disk: the unit tests get their own directory each
# (tests/unit/tmpdir.c), the CLI scripts theirs (tests/harness.sh's
# mktemp).  Each test's output is kept and printed whole, in the order
# given, once all have finished, so logs never interleave.
name=$1
jobs=$2
shift 2
dir=$(mktemp -d "${TMPDIR:-/tmp}/pm-each-XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT INT TERM

i=0
for t in "$@"; do
	i=$((i + 1))
	printf '%d %s\n' "$i" "$t"
done | xargs -P "$jobs" -L 1 sh -c '
	case $2 in
	*.sh) sh "$2" ;;
	*) "$2" ;;
	esac >"$0/$1.log" 2>&1 </dev/null
	echo $? >"$0/$1.rc"' "$dir"

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
echo "$name: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
