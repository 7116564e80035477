#!/bin/sh
# Runs each unit-test binary (cmocka), UNIT_JOBS at a time (default: the
# number of CPUs), and prints "unit: N passed, N failed" (tests/run-each.sh).
exec sh "$(dirname "$0")/run-each.sh" unit \
    "${UNIT_JOBS:-$(nproc 2>/dev/null || echo 1)}" "$@"
