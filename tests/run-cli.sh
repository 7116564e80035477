#!/bin/sh
# Runs each CLI test script (TAP-style "ok"/"not ok" lines, non-zero exit on
# failure) from the repository root, CLI_JOBS at a time (default: the
# number of CPUs), and prints "cli: N passed, N failed" (tests/run-each.sh).
exec sh "$(dirname "$0")/run-each.sh" cli \
    "${CLI_JOBS:-$(nproc 2>/dev/null || echo 1)}" "$@"
