#!/bin/sh
# CLI contract of pm-render: exit codes, messages, outputs.
# Run from the repository root: sh tests/cli/render.sh
n=0
fail=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
R=${BIN:-bin}/pm-render

check() { # description, then a command whose status decides
	n=$((n + 1))
	desc=$1
	shift
	if "$@"; then echo "ok $n - $desc"; else echo "not ok $n - $desc"; fail=$((fail + 1)); fi
}
status() { # expected-status command...: runs command, compares exit status
	want=$1
	shift
	"$@" >"$tmp/out" 2>"$tmp/err"
	[ $? -eq "$want" ]
}

check "--help exits 0 and prints usage on stdout" status 0 $R --help
check "--help output names the synopsis" grep -q '^usage: pm-render' "$tmp/out"
check "--version exits 0" status 0 $R --version
check "unknown option exits 2" status 2 $R --no-such-option -o "$tmp/x.exr" data/cornell-box.xml
check "missing -o exits 2" status 2 $R data/cornell-box.xml
check "bad --spp exits 2" status 2 $R --spp 0 -o "$tmp/x.exr" data/cornell-box.xml
check "--spp with trailing junk exits 2" status 2 $R --spp 4x -o "$tmp/x.exr" data/cornell-box.xml
check "bad --size exits 2" status 2 $R --size 10 -o "$tmp/x.exr" data/cornell-box.xml
check "--eye without --target exits 2" status 2 $R --eye 0,0,0 -o "$tmp/x.exr" data/cornell-box.xml
check "missing scene exits 1" status 1 $R -o "$tmp/x.exr" "$tmp/nope.xml"
check "the message names the missing scene" grep -q "nope.xml" "$tmp/err"
check "the message is one line" test "$(wc -l <"$tmp/err")" -eq 1
check "unwritable output directory exits 1" status 1 $R -o "$tmp/no/such/dir/x.exr" data/cornell-box.xml
check "...before rendering, naming the directory" grep -q "no/such/dir" "$tmp/err"
printf '<scene version="3.0.0">\n<shape type="nosuch"/>\n</scene>\n' >"$tmp/bad.xml"
check "unknown plugin exits 1" status 1 $R -o "$tmp/x.exr" "$tmp/bad.xml"
check "...naming file and line" grep -q "bad.xml:2" "$tmp/err"
check "a small render succeeds" status 0 $R -q --spp 2 --size 24x16 -o "$tmp/a.exr" data/cornell-box.xml
check "...and writes the file" test -s "$tmp/a.exr"
check "...leaving no temporary file behind" test "$(ls "$tmp" | grep -c '^a\.exr.')" -eq 0
check "-D overrides a default" status 0 $R -q -D spp=1 -D res=8 -o "$tmp/b.exr" data/cornell-box.xml
check "1 and 4 threads give identical files" sh -c "$R -q -t 1 --spp 2 --size 20x20 -o $tmp/t1.exr data/cornell-box.xml && $R -q -t 4 --spp 2 --size 20x20 -o $tmp/t4.exr data/cornell-box.xml && cmp -s $tmp/t1.exr $tmp/t4.exr"
check "different seeds give different images" sh -c "$R -q --seed 1 --spp 1 --size 16x16 -o $tmp/s1.exr data/cornell-box.xml && ! cmp -s $tmp/s1.exr $tmp/t1.exr"

echo "render cli: $((n - fail)) passed, $fail failed"
[ "$fail" -eq 0 ]
