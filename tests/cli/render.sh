#!/bin/sh
# CLI contract of pm-render: exit codes, messages, outputs.
# Run from the repository root: sh tests/cli/render.sh
. tests/harness.sh
R=$BIN/pm-render

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
# Images are compared by their pixels: the files differ in the command
# line they record.
check "1 and 4 threads give identical pixels" sh -c "$R -q -t 1 --spp 2 --size 20x20 -o $tmp/t1.exr data/cornell-box.xml && $R -q -t 4 --spp 2 --size 20x20 -o $tmp/t4.exr data/cornell-box.xml && $EXRUTIL same $tmp/t1.exr $tmp/t4.exr >/dev/null"
check "different seeds give different images" sh -c "$R -q --seed 1 --spp 2 --size 20x20 -o $tmp/s1.exr data/cornell-box.xml && ! $EXRUTIL same $tmp/s1.exr $tmp/t1.exr 2>/dev/null"

# Mitsuba's moment wrapper renders its nested integrator and writes its
# moments as Mitsuba names them: _arg_0.X.. and m2__arg_0.X.. for a nested
# integrator without a name, NAME.X.. with one.
sed 's|<integrator type="path">|<integrator type="moment"><integrator type="path">|; s|</integrator>|</integrator></integrator>|' \
    data/cornell-box.xml >"$tmp/moment.xml"
check "a scene under the moment integrator renders" status 0 $R -q --seed 1 --spp 2 --size 20x20 -o "$tmp/mo.exr" "$tmp/moment.xml"
check "...the nested integrator's image" sh -c "$EXRUTIL same $tmp/mo.exr $tmp/s1.exr >/dev/null"
check "...with its moments as Mitsuba's channels" sh -c \
    "$EXRUTIL channels $tmp/mo.exr | cut -f1 | tr '\n' ' ' | grep -qx '_arg_0.X _arg_0.Y _arg_0.Z m2__arg_0.X m2__arg_0.Y m2__arg_0.Z var(_arg_0.X) var(_arg_0.Y) var(_arg_0.Z) '"
check "...whose second moment is at least the first's square" sh -c \
    "$EXRUTIL channels $tmp/mo.exr | awk -F'\t' '/^var/ { if (\$2 < -1e-4) bad = 1 } END { exit bad }'"
sed 's|<integrator type="path">|<integrator type="moment"><integrator type="path" name="nested">|; s|</integrator>|</integrator></integrator>|' \
    data/cornell-box.xml >"$tmp/moment-named.xml"
check "a named nested integrator names the channels" sh -c \
    "$R -q --seed 1 --spp 2 --size 20x20 -o $tmp/mon.exr $tmp/moment-named.xml && $EXRUTIL channels $tmp/mon.exr | grep -q '^m2_nested.Y'"
sed 's|<integrator type="path">|<integrator type="moment"><integrator type="ptracer">|; s|</integrator>|</integrator></integrator>|' \
    data/cornell-box.xml >"$tmp/moment-pt.xml"
check "moment around ptracer is refused" status 1 $R -q --spp 1 --size 8x8 -o "$tmp/x.exr" "$tmp/moment-pt.xml"
check "...in one line" one_line

# Mitsuba's particle tracer: from the scene or --method ptracer; the same
# pixels whatever the thread count.
sed 's|<integrator type="path">|<integrator type="ptracer">|' data/cornell-box.xml >"$tmp/pt.xml"
check "a ptracer scene renders" status 0 $R -q -t 1 --seed 2 --spp 2 --size 20x16 -o "$tmp/pt1.exr" "$tmp/pt.xml"
check "...the same pixels with 3 threads" sh -c "$R -q -t 3 --seed 2 --spp 2 --size 20x16 -o $tmp/pt3.exr $tmp/pt.xml && $EXRUTIL same $tmp/pt1.exr $tmp/pt3.exr >/dev/null"
check "...as --method ptracer on the path scene" sh -c "$R -q -t 2 --method ptracer --seed 2 --spp 2 --size 20x16 -o $tmp/ptm.exr data/cornell-box.xml && $EXRUTIL same $tmp/pt1.exr $tmp/ptm.exr >/dev/null"
check "--method path overrides the scene's ptracer" sh -c "$R -q --method path --seed 1 --spp 2 --size 20x20 -o $tmp/ptp.exr $tmp/pt.xml && $EXRUTIL same $tmp/ptp.exr $tmp/s1.exr >/dev/null"
check "--method ptracer with a map exits 2" status 2 $R --method ptracer -o "$tmp/x.exr" data/cornell-box.xml "$tmp/x.pmap"
check "an unknown method exits 2" status 2 $R --method bdpt -o "$tmp/x.exr" data/cornell-box.xml

# Photon maps: the map must come from the scene; several cameras, one load.
B=$BIN
if $B/pm-shoot -q -f --photons 2000 --caustic-photons 0 -o "$tmp/cb-shot.pmap" data/cornell-box.xml &&
    $B/pm-balance -q -f -o "$tmp/cb.pmap" "$tmp/cb-shot.pmap"; then
	check "a photon render succeeds" status 0 $R -q --spp 1 --size 16x16 -o "$tmp/pm.exr" data/cornell-box.xml "$tmp/cb.pmap"
	check "a map from another scene is refused" status 1 $R -q --spp 1 --size 8x8 -o "$tmp/x.exr" data/caustics.xml "$tmp/cb.pmap"
	check "...saying why" grep -q "another scene" "$tmp/err"
	check "an unbalanced map is refused" status 1 $R -q --spp 1 --size 8x8 -o "$tmp/x.exr" data/cornell-box.xml "$tmp/cb-shot.pmap"
	check "...naming pm-balance" grep -q "pm-balance" "$tmp/err"
	check "--method path with a map is a usage error" status 2 $R --method path -o "$tmp/x.exr" data/cornell-box.xml "$tmp/cb.pmap"
	check "photon mode writes the moments too" sh -c "$R -q --spp 2 --size 16x16 -o $tmp/pmo.exr $tmp/moment.xml $tmp/cb.pmap && $EXRUTIL channels $tmp/pmo.exr | grep -q '^m2__arg_0.Y'"
	printf '# two cameras\n0,1,3.8 0,1,0 0,1,0\n\n0.5,1,3.8 0,1,0 0,1,0 50\n' >"$tmp/cams.txt"
	check "--cameras renders every camera" status 0 $R -q --spp 1 --size 8x8 --cameras "$tmp/cams.txt" -o "$tmp/cam.exr" data/cornell-box.xml "$tmp/cb.pmap"
	check "...numbering the outputs" test -s "$tmp/cam-0001.exr" -a -s "$tmp/cam-0002.exr" -a ! -e "$tmp/cam-0003.exr"
	check "...or filling a %d pattern" status 0 $R -q --spp 1 --size 8x8 --cameras "$tmp/cams.txt" -o "$tmp/f%02d.exr" data/cornell-box.xml
	check "...as asked" test -s "$tmp/f01.exr" -a -s "$tmp/f02.exr"
	check "the same camera renders the same image from --cameras and from --eye" sh -c "$R -q --spp 1 --size 8x8 --eye 0,1,3.8 --target 0,1,0 -o $tmp/eye.exr data/cornell-box.xml $tmp/cb.pmap && $EXRUTIL same $tmp/eye.exr $tmp/cam-0001.exr >/dev/null"
	printf '0,1,3.8 0,1,0\n' >"$tmp/bad-cams.txt"
	check "a malformed camera line exits 1" status 1 $R -q --cameras "$tmp/bad-cams.txt" -o "$tmp/x.exr" data/cornell-box.xml
	check "...naming the file and line" grep -q "bad-cams.txt:1:" "$tmp/err"
else
	check "pm-shoot and pm-balance make a map" false
fi

finish render
