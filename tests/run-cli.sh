#!/bin/sh
# Runs each CLI test script (TAP-style "ok"/"not ok" lines, non-zero exit on
# failure) from the repository root; prints "cli: N passed, N failed".
pass=0
fail=0
for t in "$@"; do
	if sh "$t"; then
		pass=$((pass + 1))
	else
		echo "FAILED: $t"
		fail=$((fail + 1))
	fi
done
echo "cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
