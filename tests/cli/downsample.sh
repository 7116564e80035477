#!/bin/sh
# CLI contract of pm-downsample: exit codes, messages, and what lands in the
# output files.  Run from the repository root: sh tests/cli/downsample.sh
#
# Inputs are made, and outputs measured, by tests/cli/exrutil.c; set
# EXRUTIL to a built copy (the harness's default, build/tests/exrutil), or
# this script compiles one with $CC into its temporary directory.
. tests/harness.sh
D=$BIN/pm-downsample

no_temp() { # nothing but the named files in $tmp/o
	[ "$(ls -A "$tmp/o" | grep -v -x -e "$1" -e "${2:-$1}" | wc -l)" -eq 0 ]
}

if [ ! -x "$D" ]; then
	echo "not ok 1 - $D is not built (make all)"
	exit 1
fi
U=$EXRUTIL
if [ ! -x "$U" ]; then
	U=$tmp/exrutil
	if ! ${CC:-cc} -std=c17 -O2 -D_DEFAULT_SOURCE -I/usr/include/OpenEXR \
	    $(pkg-config --cflags libpng 2>/dev/null) -o "$U" tests/cli/exrutil.c \
	    common/image.c common/error.c formats/exr.c formats/tmpfile.c -lOpenEXRCore \
	    $(pkg-config --libs libpng 2>/dev/null || echo -lpng) -lm; then
		echo "not ok 1 - cannot build tests/cli/exrutil.c"
		exit 1
	fi
fi
mkdir "$tmp/o"
"$U" make "$tmp/a.exr" 8 6 1 2 3 &&
"$U" make "$tmp/b.exr" 8 6 3 6 7 &&
"$U" make "$tmp/ramp.exr" 8 6 0 0.5 1 ramp &&
"$U" make "$tmp/odd.exr" 5 4 1 1 1 &&
"$U" make "$tmp/small.exr" 4 6 1 1 1 &&
"$U" make "$tmp/bright.exr" 4 4 1000 1e30 0.5 &&
"$U" make "$tmp/dark.exr" 4 4 -1 -1000 0 || { echo "not ok 1 - exrutil make"; exit 1; }
printf 'not an image\n' >"$tmp/text.exr"

# Options and usage.
check "--help exits 0" status 0 $D --help
check "...printing the usage line on stdout" grep -q '^usage: pm-downsample ' "$tmp/out"
check "...and nothing on stderr" test ! -s "$tmp/err"
usage=$(sed -n 's/^usage: //p' "$tmp/out")
bs=$(printf '\b')
synopsis=$(mandoc -T ascii -O width=200 man/pm-downsample.1 | sed "s/.$bs//g" |
	awk '/^SYNOPSIS/ { getline; sub(/^ +/, ""); print; exit }')
check "the usage line is the man page's SYNOPSIS" same "$usage" "$synopsis"
check "--version exits 0" status 0 $D --version
check "...naming the tool" grep -q '^pm-downsample ' "$tmp/out"
check "unknown option exits 2" status 2 $D --no-such-option -o "$tmp/o/x.exr" "$tmp/a.exr"
check "...with one line on stderr" one_line pm-downsample
check "missing -o exits 2" status 2 $D "$tmp/a.exr"
check "no input exits 2" status 2 $D -o "$tmp/o/x.exr"
check "--factor 0 exits 2" status 2 $D --factor 0 -o "$tmp/o/x.exr" "$tmp/a.exr"
check "--factor with trailing junk exits 2" status 2 $D --factor 2x -o "$tmp/o/x.exr" "$tmp/a.exr"
check "--factor overflowing exits 2" status 2 $D --factor 99999999999999999999 -o "$tmp/o/x.exr" "$tmp/a.exr"
check "...with one line naming the option" sh -c "grep -q -- '--factor' '$tmp/err' && [ \$(wc -l <'$tmp/err') -eq 1 ]"
check "unknown filter exits 2" status 2 $D --filter sinc -o "$tmp/o/x.exr" "$tmp/a.exr"
check "non-numeric exposure exits 2" status 2 $D --exposure bright -o "$tmp/o/x.png" "$tmp/a.exr"
check "output of unknown format exits 2" status 2 $D -o "$tmp/o/x.jpg" "$tmp/a.exr"
check "--half with PNG output exits 2" status 2 $D --half -o "$tmp/o/x.png" "$tmp/a.exr"
check "option without its argument exits 2" status 2 $D "$tmp/a.exr" -o
check "no output was written by any of these" no_temp ""

# Runtime errors.
check "missing input exits 1" status 1 $D -o "$tmp/o/x.exr" "$tmp/nope.exr"
check "...naming the file in one line" sh -c "grep -q 'nope.exr' '$tmp/err' && [ \$(wc -l <'$tmp/err') -eq 1 ]"
check "a file that is not OpenEXR exits 1" status 1 $D -o "$tmp/o/x.exr" "$tmp/text.exr"
check "...naming the file" grep -q '^pm-downsample: .*text.exr: ' "$tmp/err"
check "a size not divisible by the factor exits 1" status 1 $D --factor 2 -o "$tmp/o/x.exr" "$tmp/odd.exr"
check "...naming the file and the size" grep -q 'odd.exr: size 5x4 .*divisible' "$tmp/err"
check "inputs of different sizes exit 1" status 1 $D -o "$tmp/o/x.exr" "$tmp/a.exr" "$tmp/small.exr"
check "...naming the odd one and both sizes" grep -q 'small.exr: size 4x6 differs .*8x6' "$tmp/err"
check "an output directory that does not exist exits 1" status 1 $D -o "$tmp/no/such/x.exr" "$tmp/a.exr"
check "...naming the output" grep -q 'no/such/x.exr' "$tmp/err"
check "no temporary file is left after failures" no_temp ""
cp "$tmp/a.exr" "$tmp/o/keep.exr"
check "a failed run leaves an existing output alone" sh -c "! $D -o '$tmp/o/keep.exr' '$tmp/nope.exr' 2>/dev/null && cmp -s '$tmp/a.exr' '$tmp/o/keep.exr'"
rm -f "$tmp/o/keep.exr"

# Results.
check "factor 1 copies an image" status 0 $D -o "$tmp/o/copy.exr" "$tmp/ramp.exr"
check "...exactly" same "$("$U" stat "$tmp/o/copy.exr")" "$("$U" stat "$tmp/ramp.exr")"
check "...quietly" test ! -s "$tmp/err"
check "averaging two images succeeds" status 0 $D -o "$tmp/o/mean.exr" "$tmp/a.exr" "$tmp/b.exr"
check "...giving their mean" same "$("$U" stat "$tmp/o/mean.exr")" "8 6 2 4 5 2 5"
check "the same image three times averages to itself" status 0 $D -o "$tmp/o/three.exr" "$tmp/ramp.exr" "$tmp/ramp.exr" "$tmp/ramp.exr"
check "...within float rounding" sh -c "\"$U\" stat '$tmp/o/three.exr' | awk '{ exit !(\$1 == 8 && \$2 == 6 && \$3 > 0.4374999 && \$3 < 0.4375001) }'"
for f in box tent gaussian mitchell lanczos; do
	check "factor 2 with $f halves the size" status 0 $D --factor 2 -F $f -o "$tmp/o/$f.exr" "$tmp/a.exr"
	check "...and keeps a constant image constant" same "$("$U" stat "$tmp/o/$f.exr")" "4 3 1 2 3 1 3"
done
check "a box halving keeps the mean of a ramp" status 0 $D --factor 2 -o "$tmp/o/rbox.exr" "$tmp/ramp.exr"
check "...exactly" sh -c "[ \"\$(\"$U\" stat '$tmp/o/rbox.exr' | cut -d' ' -f3-5)\" = \"\$(\"$U\" stat '$tmp/ramp.exr' | cut -d' ' -f3-5)\" ]"
check "--half writes a readable file" status 0 $D --half -o "$tmp/o/half.exr" "$tmp/a.exr"
check "...with the same values (exact in half)" same "$("$U" stat "$tmp/o/half.exr")" "8 6 1 2 3 1 3"
check "...smaller than the float one" test "$(wc -c <"$tmp/o/half.exr")" -lt "$(wc -c <"$tmp/o/copy.exr")"
check "PNG output succeeds" status 0 $D --factor 2 -o "$tmp/o/x.png" "$tmp/a.exr"
check "...at half the size" sh -c "\"$U\" pngstat '$tmp/o/x.png' | grep -q '^4 3 '"
check "bright values saturate at 255, never wrap" status 0 $D -o "$tmp/o/bright.png" "$tmp/bright.exr"
check "...(0.5 is the only value below)" same "$("$U" pngstat "$tmp/o/bright.png")" "4 4 188 255"
check "negative values are black" status 0 $D -o "$tmp/o/dark.png" "$tmp/dark.exr"
check "...all of them" same "$("$U" pngstat "$tmp/o/dark.png")" "4 4 0 0"
check "--exposure -1 halves before the curve" status 0 $D -e -1 -o "$tmp/o/exp.png" "$tmp/bright.exr"
check "...so 0.5 becomes 0.25, sRGB 137" same "$("$U" pngstat "$tmp/o/exp.png")" "4 4 137 255"
check "-v describes the work on stderr" status 0 $D -v --factor 2 -o "$tmp/o/v.exr" "$tmp/a.exr" "$tmp/b.exr"
check "...naming the inputs and the sizes" sh -c "grep -q 'b.exr: 8x6' '$tmp/err' && grep -q '8x6 -> 4x3' '$tmp/err'"
check "no temporary file is left after successes" sh -c "[ \$(ls -A '$tmp/o' | grep -c -v '\\.\\(exr\\|png\\)\$') -eq 0 ]"
check "-o - writes PNG to a pipe" sh -c "$D -o - '$tmp/a.exr' | od -A n -t x1 -N 8 | grep -q '89 50 4e 47 0d 0a 1a 0a'"
if [ -w /dev/full ]; then
	check "a full standard output exits 1" sh -c "$D -o - '$tmp/a.exr' >/dev/full 2>'$tmp/err'; [ \$? -eq 1 ]"
	check "...saying so in one line" one_line pm-downsample
else
	skip "a full standard output exits 1: no /dev/full"
	skip "...saying so in one line: no /dev/full"
fi

# Channels beside R, G and B (the moment integrator's) are averaged and
# filtered with the image: the means of two passes' moments, halved in
# size, are the mean of their means.
R=$BIN/pm-render
if [ -x "$R" ]; then
	sed 's|<integrator type="path">|<integrator type="moment"><integrator type="path" name="nested">|; s|</integrator>|</integrator></integrator>|' \
	    data/cornell-box.xml >"$tmp/moment.xml"
	"$R" -q --seed 1 --spp 2 --size 16x12 -o "$tmp/m1.exr" "$tmp/moment.xml" &&
	"$R" -q --seed 2 --spp 2 --size 16x12 -o "$tmp/m2.exr" "$tmp/moment.xml" &&
	"$R" -q --seed 1 --spp 2 --size 16x12 -o "$tmp/plain.exr" data/cornell-box.xml ||
	    echo "# pm-render failed"
	check "passes with moments average" status 0 $D --factor 2 -o "$tmp/o/mo.exr" "$tmp/m1.exr" "$tmp/m2.exr"
	check "...keeping every channel" same "$("$U" channels "$tmp/o/mo.exr" | cut -f1 | tr '\n' ' ')" \
	    "m2_nested.X m2_nested.Y m2_nested.Z nested.X nested.Y nested.Z var(nested.X) var(nested.Y) var(nested.Z) "
	check "...each the mean of the passes'" sh -c "\"$U\" channels '$tmp/m1.exr' >'$tmp/c1' &&
	    \"$U\" channels '$tmp/m2.exr' >'$tmp/c2' && \"$U\" channels '$tmp/o/mo.exr' >'$tmp/co' &&
	    paste '$tmp/c1' '$tmp/c2' '$tmp/co' | awk -F'\t' '
		\$1 !~ /^var/ { m = (\$2 + \$4) / 2; d = \$6 - m; if (d < 0) d = -d;
		    if (d > 1e-5 * (m < 0 ? -m : m) + 1e-9) bad = 1; n++ }
		END { exit bad || n != 6 }'"
	check "...and the second moment stays at least the first's square" sh -c \
	    "\"$U\" channels '$tmp/o/mo.exr' | awk -F'\t' '/^var/ { if (\$2 < -1e-4) bad = 1 } END { exit bad }'"
	check "passes with different channels are refused" status 1 $D -o "$tmp/o/mix.exr" "$tmp/m1.exr" "$tmp/plain.exr"
	check "...in one line naming both" one_line pm-downsample 'plain.exr: its channels differ from .*m1.exr'
	check "PNG from passes with moments" status 0 $D -o "$tmp/o/mo.png" "$tmp/m1.exr" "$tmp/m2.exr"
else
	skip "moments through pm-downsample: $R is not built"
fi

finish downsample
