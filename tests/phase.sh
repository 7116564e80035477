#!/bin/sh
# phase.sh FILE NAME COMMAND...: runs COMMAND, then prints how long it took
# and appends "NAME SECONDS" to FILE, so that `make test` can end with every
# phase's time on one line: a CI log shows its last lines, and CI has a time
# limit.  Exits with COMMAND's status.
file=$1
name=$2
shift 2
t0=$(date +%s)
"$@"
rc=$?
s=$(($(date +%s) - t0))
echo "$name $s" >>"$file"
echo "make test: $name took $s s (exit $rc)"
exit $rc
