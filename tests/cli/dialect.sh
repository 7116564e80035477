#!/bin/sh
# The one CLI dialect of all six tools: --help (stdout, exit 0) whose usage
# is the man page's SYNOPSIS word for word, one --version, usage errors as
# one line with exit 2, -f/--force for every tool that writes, the command
# line recorded shell-quoted, the progress line only on a terminal, and
# pm-render's --preview.
# Run from the repository root: sh tests/cli/dialect.sh
. tests/harness.sh
B=$BIN
TOOLS="pm-shoot pm-balance pm-render pm-downsample pm-inspect pm-merl"
scene=data/cornell-box.xml

# synopsis TOOL: the man page's SYNOPSIS as one line of words.
synopsis() {
	mandoc -T ascii -O width=1000 "man/$1.1" | sed "s/.$(printf '\b')//g" |
	    awk '/^SYNOPSIS/ { on = 1; next } /^[A-Z]/ { on = 0 } on' |
	    tr -s ' \n\t' '   ' | sed 's/^ //; s/ $//'
}
# usage: the usage lines of $tmp/out (up to the first blank line) as one
# line of words, without "usage:".
usage() {
	awk '/^$/ { exit } { print }' "$tmp/out" | sed '1s/^usage: //' |
	    tr -s ' \n\t' '   ' | sed 's/^ //; s/ $//'
}

want_version=$(sed -n 's/^#define PM_VERSION "\(.*\)"$/\1/p' tools/cli.h)
check "tools/cli.h defines PM_VERSION" test -n "$want_version"

for t in $TOOLS; do
	T=$B/$t
	check "$t --help exits 0 with nothing on stderr" status 0 $T --help
	check "$t --help: stderr empty" test ! -s "$tmp/err"
	check "$t --help: usage is the man page's SYNOPSIS" same "$(usage)" "$(synopsis $t)"
	check "$t --help lists the options (-h, --version)" sh -c "grep -q -- '--version' '$tmp/out' && grep -q -- '-h, --help' '$tmp/out'"
	cp "$tmp/out" "$tmp/help"
	check "$t -h exits 0" status 0 $T -h
	check "$t -h prints what --help prints" cmp -s "$tmp/out" "$tmp/help"
	check "$t --version exits 0" status 0 $T --version
	check "$t --version prints the one project version" same "$(cat "$tmp/out")" "$t (pm) $want_version"
	check "$t: an unknown long option exits 2" status 2 $T --no-such-option
	check "...with one line naming it" one_line $t "unknown option '--no-such-option' (see --help)"
	check "$t: an unknown short option exits 2" status 2 $T -Z
	check "...with one line naming it" one_line $t "unknown option '-Z'"
	check "$t: an option that takes no argument, given one, exits 2" status 2 $T --version=1
	check "...with one line" one_line $t "takes no argument"
done

# A missing argument, short and long, for each tool.
for a in "pm-shoot -o" "pm-shoot --photons" "pm-balance -o" "pm-balance --threads" \
    "pm-render -o" "pm-render --spp" "pm-render --preview-every" "pm-downsample -o" \
    "pm-downsample --factor" "pm-inspect -k" "pm-inspect --seed" "pm-merl -o" "pm-merl --alpha"; do
	t=${a%% *}
	check "$a without its argument exits 2" status 2 $B/$a
	check "...with one line saying so" one_line $t "needs an argument"
done
check "-D without = exits 2" status 2 $B/pm-render -D spp -o "$tmp/x.exr" $scene
check "...with one line" one_line pm-render "NAME=VALUE"
check "pm-downsample -f takes no factor: -f 2 reads an input named 2" status 1 $B/pm-downsample -f 2 -o "$tmp/x.exr"
check "...and says so in one line" one_line pm-downsample "2"

# -f/--force: every tool that writes refuses an existing output without it.
: >"$tmp/exists.exr"
check "pm-render refuses to overwrite without -f" status 1 $B/pm-render -q --spp 1 --size 8x8 -o "$tmp/exists.exr" $scene
check "...in one line naming the file and -f" one_line pm-render "exists.exr: already exists (use -f"
check "...and leaves the file alone" test ! -s "$tmp/exists.exr"
check "pm-render -f overwrites" status 0 $B/pm-render -f --spp 1 --size 8x8 -o "$tmp/exists.exr" $scene
check "...writing the image" test -s "$tmp/exists.exr"
check "pm-render --force overwrites" status 0 $B/pm-render --force --spp 1 --size 8x8 -o "$tmp/exists.exr" $scene
printf '0,1,3.8 0,1,0 0,1,0\n0,1,3 0,1,0 0,1,0\n' >"$tmp/cams.txt"
: >"$tmp/cam-0002.exr"
check "pm-render --cameras checks every output before rendering" status 1 $B/pm-render -q --spp 1 --size 8x8 --cameras "$tmp/cams.txt" -o "$tmp/cam.exr" $scene
check "...naming the one that exists" one_line pm-render "cam-0002.exr: already exists"
check "...and rendering none" test ! -e "$tmp/cam-0001.exr"
cp "$tmp/exists.exr" "$tmp/in.exr"
: >"$tmp/ds.exr"
check "pm-downsample refuses to overwrite without -f" status 1 $B/pm-downsample -o "$tmp/ds.exr" "$tmp/in.exr"
check "...in one line" one_line pm-downsample "already exists"
check "pm-downsample -f overwrites" status 0 $B/pm-downsample -f --factor 2 -o "$tmp/ds.exr" "$tmp/in.exr"
: >"$tmp/s.pmap"
check "pm-shoot refuses to overwrite without -f" status 1 $B/pm-shoot --photons 100 -o "$tmp/s.pmap" $scene
check "...in one line" one_line pm-shoot "already exists"
check "pm-shoot -f overwrites" status 0 $B/pm-shoot -f --photons 1000 -o "$tmp/s.pmap" $scene
check "pm-shoot --force too" status 0 $B/pm-shoot --force --photons 1000 -D "spp=7" -o "$tmp/s s.pmap" $scene
check "pm-balance refuses to overwrite without -f" status 1 $B/pm-balance -o "$tmp/s.pmap" "$tmp/s s.pmap"
check "...in one line" one_line pm-balance "already exists"
check "pm-balance -f overwrites" status 0 $B/pm-balance -f -o "$tmp/s.pmap" "$tmp/s s.pmap"
: >"$tmp/m.binary"
check "pm-merl refuses to overwrite without -f" status 1 $B/pm-merl --gold -o "$tmp/m.binary"
check "...in one line" one_line pm-merl "already exists"

# The command line goes into the map shell-quoted, words as given.
check "pm-inspect prints the map's history" status 0 $B/pm-inspect "$tmp/s.pmap"
check "...pm-shoot's command line, words as given, quoted for the shell" grep -q -F -- "--photons 1000 -D spp=7 -o '$tmp/s s.pmap' $scene" "$tmp/out"
check "...and pm-balance's, in the order given" grep -q -F -- "pm-balance -f -o $tmp/s.pmap '$tmp/s s.pmap'" "$tmp/out"
check "...with the one version" grep -q -F "pm-shoot $want_version" "$tmp/out"

# Progress: nothing when stderr is not a terminal, even without -q.
check "pm-render without a terminal succeeds" status 0 $B/pm-render -f --spp 1 --size 16x16 -o "$tmp/p.exr" $scene
check "...and prints nothing" test ! -s "$tmp/err"
check "pm-shoot without a terminal prints nothing" status 0 $B/pm-shoot -f --photons 100000 -o "$tmp/p.pmap" $scene
check "...nothing" test ! -s "$tmp/err"
check "pm-balance without a terminal prints nothing" status 0 $B/pm-balance -f -o "$tmp/pb.pmap" "$tmp/p.pmap"
check "...nothing" test ! -s "$tmp/err"
# On a terminal (script(1) gives one), a line ending at 100%; -q silences it.
if script -qec true /dev/null >/dev/null 2>&1; then
	onterm() { # command...: runs it on a pseudo-terminal, output in $tmp/tty
		script -qec "$*" /dev/null </dev/null 2>&1 | tr '\r' '\n' >"$tmp/tty"
	}
	for c in "pm-render -f --spp 1 --size 64x64 -o $tmp/p.exr $scene" \
	    "pm-shoot -f --photons 200000 -o $tmp/p.pmap $scene" \
	    "pm-balance -f -o $tmp/pb.pmap $tmp/p.pmap"; do
		t=${c%% *}
		check "$t on a terminal" onterm $B/$c
		check "...showing a progress line that reaches 100% with the time taken" \
		    grep -q "^$t: .*100%  [0-9]*:[0-9][0-9] elapsed" "$tmp/tty"
		check "$t -q on a terminal" onterm $B/$t -q ${c#* }
		check "...shows no progress" sh -c "! grep -q '%' '$tmp/tty'"
	done
	check "pm-shoot's map is the same with and without the progress line" sh -c "
	    cd '$tmp' && mkdir -p a b && cd a &&
	    '$PWD/$B/pm-shoot' --photons 150000 -o x.pmap '$PWD/$scene' && cd ../b &&
	    script -qec \"'$PWD/$B/pm-shoot' --photons 150000 -o x.pmap '$PWD/$scene'\" /dev/null >/dev/null &&
	    cmp ../a/x.pmap x.pmap"
else
	echo "# script(1) cannot make a terminal here: progress lines not checked"
fi

# --preview: PNG or EXR, written through a temporary file, the last one
# the finished image.
check "--preview with a PNG succeeds" status 0 $B/pm-render -q -f --spp 2 --size 40x30 --preview "$tmp/pv.png" --preview-every 0.01 -o "$tmp/pv-out.exr" $scene
check "...writing a PNG" sh -c "head -c 8 '$tmp/pv.png' | od -An -c | grep -q 'P   N   G'"
check "...leaving no temporary file" sh -c "! ls '$tmp' | grep -q 'pv.png.'"
check "--preview with an EXR succeeds" status 0 $B/pm-render -q -f --spp 2 --size 40x30 --preview "$tmp/pv.exr" -o "$tmp/pv-out.exr" $scene
if [ -n "${EXRUTIL:-}" ] && [ -x "$EXRUTIL" ]; then
	# The preview is in half floats: the same image to 3 digits.
	check "...whose last write is the finished image" sh -c "
	    { '$EXRUTIL' stat '$tmp/pv.exr' && '$EXRUTIL' stat '$tmp/pv-out.exr'; } |
	    awk 'NR == 1 { for (i = 1; i <= 5; i++) a[i] = \$i; next }
		{ for (i = 1; i <= 5; i++) { d = a[i] - \$i; if (d < 0) d = -d;
		  if (d > 1e-3 * (\$i < 0 ? -\$i : \$i) + 1e-6) exit 1 } }
		END { if (NR != 2) exit 1 }'"
fi
check "the image is the same with and without --preview" sh -c "
    $B/pm-render -q -f --spp 2 --size 40x30 -o '$tmp/nopv.exr' $scene &&
    $B/pm-render -q -f --spp 2 --size 40x30 --preview '$tmp/pv2.png' --preview-every 0.01 -o '$tmp/pv-out.exr' $scene &&
    '$EXRUTIL' same '$tmp/nopv.exr' '$tmp/pv-out.exr' >/dev/null"
check "--preview - is a usage error" status 2 $B/pm-render --preview - -o "$tmp/x.exr" $scene
check "...in one line" one_line pm-render "preview"
check "--preview-every 0 is a usage error" status 2 $B/pm-render --preview "$tmp/x.png" --preview-every 0 -o "$tmp/x.exr" $scene
check "...in one line" one_line pm-render "preview-every"

finish dialect
