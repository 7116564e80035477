# harness.sh: what the CLI test scripts share, sourced from the repository
# root (". tests/harness.sh"): the tools in $BIN, the image helper
# tests/cli/exrutil.c built as $EXRUTIL, a scratch directory $tmp removed
# on exit, TAP-style checks counted in $n and $fail, and a closing line.

BIN=${BIN:-bin}
EXRUTIL=${EXRUTIL:-build/tests/exrutil}
n=0
fail=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

check() { # description, then a command whose status decides
	n=$((n + 1))
	desc=$1
	shift
	if "$@"; then echo "ok $n - $desc"; else echo "not ok $n - $desc"; fail=$((fail + 1)); fi
}
skip() { # description: a check that cannot run here, counted as passed
	n=$((n + 1))
	echo "ok $n # SKIP $1"
}
status() { # expected-status command...: runs it (stdin empty), output in $tmp/out and $tmp/err
	want=$1
	shift
	"$@" >"$tmp/out" 2>"$tmp/err" </dev/null
	[ $? -eq "$want" ]
}
same() { # got want: two strings, shown when they differ
	[ "$1" = "$2" ] || { echo "# got  '$1'"; echo "# want '$2'"; false; }
}
one_line() { # [tool [pattern]]: after status, stdout empty and stderr one
	# line, "tool: ..." when a tool is named, matching the pattern if given
	[ "$(wc -l <"$tmp/err")" -eq 1 ] && [ ! -s "$tmp/out" ] &&
	    { [ -z "${1:-}" ] || grep -q "^$1: " "$tmp/err"; } &&
	    grep -q -e "${2:-.}" "$tmp/err" ||
	    { sed 's/^/# /' "$tmp/err"; false; }
}
finish() { # name: the closing line; the script's exit status
	echo "$1 cli: $((n - fail)) passed, $fail failed"
	[ "$fail" -eq 0 ]
}
