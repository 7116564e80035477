#!/bin/sh
# Hard but valid scenes through the whole pipeline (pm-shoot, pm-balance,
# pm-render): no sample or photon may be dropped as NaN or infinite (the
# tools count them with -v), and the same scene at millimetre, metre and
# kilometre scale gives the same image up to noise.
# Run from the repository root: sh tests/cli/hard.sh
. tests/harness.sh
R=$BIN/pm-render
S=$BIN/pm-shoot
B=$BIN/pm-balance

none_dropped() { # the -v report of the last command says "0 ... dropped"
	grep -q 'dropped' "$tmp/err" && ! grep 'dropped' "$tmp/err" | grep -qv ' 0 [a-z -]*dropped\|, 0 dropped'
}
within() { # a b tolerance: |a - b| <= tolerance * |b|
	awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d;
	    if (b < 0) b = -b; exit !(d <= t * b) }'
}
mean_r() { $EXRUTIL stat "$1" | awk '{ print $3 }'; }

# A closed box with a glass sphere, a diffuse sphere and a sphere light,
# every length times $1.
box() {
	awk -v s="$1" 'BEGIN {
	printf "<scene version=\"3.0.0\">\n"
	printf "<integrator type=\"photonmapper\"><float name=\"globalLookupRadius\" value=\"0.1\"/></integrator>\n"
	printf "<sensor type=\"perspective\"><float name=\"fov\" value=\"75\"/>"
	printf "<float name=\"near_clip\" value=\"%.9g\"/><float name=\"far_clip\" value=\"%.9g\"/>\n", 0.01 * s, 100 * s
	printf "<transform name=\"to_world\"><lookat origin=\"0, %.9g, %.9g\" target=\"0, %.9g, 0\" up=\"0, 1, 0\"/></transform>\n", s, 0.95 * s, s
	printf "<film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/><integer name=\"height\" value=\"32\"/></film></sensor>\n"
	printf "<bsdf type=\"diffuse\" id=\"white\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf>\n"
	printf "<bsdf type=\"dielectric\" id=\"glass\"/>\n"
	printf "<shape type=\"cube\"><boolean name=\"flip_normals\" value=\"true\"/><transform name=\"to_world\"><translate y=\"1\"/><scale value=\"%.9g\"/></transform><ref id=\"white\"/></shape>\n", s
	printf "<shape type=\"sphere\"><point name=\"center\" x=\"%.9g\" y=\"%.9g\" z=\"0\"/><float name=\"radius\" value=\"%.9g\"/><ref id=\"glass\"/></shape>\n", 0.4 * s, 0.35 * s, 0.35 * s
	printf "<shape type=\"sphere\"><point name=\"center\" x=\"%.9g\" y=\"%.9g\" z=\"%.9g\"/><float name=\"radius\" value=\"%.9g\"/><ref id=\"white\"/></shape>\n", -0.4 * s, 0.3 * s, -0.3 * s, 0.3 * s
	printf "<shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"%.9g\" z=\"0\"/><float name=\"radius\" value=\"%.9g\"/>", 1.7 * s, 0.15 * s
	printf "<emitter type=\"area\"><rgb name=\"radiance\" value=\"20\"/></emitter></shape>\n"
	printf "</scene>\n" }'
}

for s in 1e-3 1 1e3; do
	box $s >"$tmp/box-$s.xml"
	check "scale $s: pm-shoot drops no photon" status 0 $S -v --photons 20000 --caustic-photons 20000 -o "$tmp/box-$s.pmap" "$tmp/box-$s.xml"
	check "...(-v says 0 dropped)" none_dropped
	check "scale $s: pm-balance" status 0 $B -q -o "$tmp/box-$s.bal" "$tmp/box-$s.pmap"
	check "scale $s: the photon render drops no sample" status 0 $R -v --spp 4 -o "$tmp/pm-$s.exr" "$tmp/box-$s.xml" "$tmp/box-$s.bal"
	check "...(-v says 0 dropped)" none_dropped
	check "scale $s: the path-traced render drops no sample" status 0 $R -v --spp 16 -o "$tmp/pt-$s.exr" "$tmp/box-$s.xml"
	check "...(-v says 0 dropped)" none_dropped
done
for s in 1e-3 1e3; do
	check "scale $s: the path-traced image matches scale 1 (2%)" within "$(mean_r "$tmp/pt-$s.exr")" "$(mean_r "$tmp/pt-1.exr")" 0.02
	check "scale $s: the photon-mapped image matches scale 1 (3%)" within "$(mean_r "$tmp/pm-$s.exr")" "$(mean_r "$tmp/pm-1.exr")" 0.03
done

# The shipped scenes, small: nothing dropped either way.
for f in cornell-box caustics materials point-lights sky; do
	check "$f: pm-shoot drops no photon" status 0 $S -v --photons 5000 --caustic-photons 5000 -o "$tmp/$f.pmap" "data/$f.xml"
	check "...(-v says 0 dropped)" none_dropped
	$B -q -o "$tmp/$f.bal" "$tmp/$f.pmap"
	check "$f: the photon render drops no sample" status 0 $R -v --spp 2 --size 16x16 -o "$tmp/$f.exr" "data/$f.xml" "$tmp/$f.bal"
	check "...(-v says 0 dropped)" none_dropped
	check "$f: the path-traced render drops no sample" status 0 $R -v --spp 2 --size 16x16 -o "$tmp/$f-pt.exr" "data/$f.xml"
	check "...(-v says 0 dropped)" none_dropped
done

finish hard
