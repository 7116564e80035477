#!/bin/sh
# The photon-map render agrees with the path-traced reference: on
# data/cornell-box.xml and data/caustics.xml the image means agree within 2%
# per channel, and the error against the reference falls as photons grow;
# the scene's max_depth limits both alike.
# Run from the repository root: sh tests/cli/agreement.sh
. tests/harness.sh
B=$BIN
U=$EXRUTIL

# within A B TOL: |A - B| <= TOL, all decimals
within() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= t) }'; }
less() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a < b) }'; }

# map SCENE NAME GLOBAL CAUSTIC: shoot and balance
map() {
	$B/pm-shoot -q -f --photons "$3" --caustic-photons "$4" --seed 7 \
	    -o "$tmp/$2-shot.pmap" "$1" &&
	$B/pm-balance -q -f -o "$tmp/$2.pmap" "$tmp/$2-shot.pmap"
}

# agree SCENE NAME PATH_SPP: photon render against a long path reference
agree() {
	scene=$1
	name=$2
	if ! map "$scene" "$name" 300000 300000 ||
	    ! $B/pm-render -q --spp 256 --size 64x64 --direct-samples 1 \
	        -o "$tmp/$name-pm.exr" "$scene" "$tmp/$name.pmap" ||
	    ! $B/pm-render -q --spp "$3" --size 64x64 -o "$tmp/$name-path.exr" \
	        "$scene"; then
		check "$name: renders" false
		return
	fi
	set -- $($U relmse "$tmp/$name-pm.exr" "$tmp/$name-path.exr")
	echo "# $name: photon map against path tracing: relMSE $1, mean R $2 G $3 B $4"
	check "$name: mean R within 2% of path tracing" within "$2" 0 0.02
	check "$name: mean G within 2% of path tracing" within "$3" 0 0.02
	check "$name: mean B within 2% of path tracing" within "$4" 0 0.02
}

agree data/cornell-box.xml cornell-box 1024
agree data/caustics.xml caustics 2048

# max_depth means the same in both modes: the scene's max_depth counts
# path segments, camera to light, and pm-shoot, pm-balance and pm-render
# keep the photon paths to it (3: direct light and one bounce; 4: two).
for md in 3 4; do
	if $B/pm-shoot -q -f -D max_depth=$md --seed 5 --photons 100000 -o "$tmp/md.shot" data/cornell-box.xml &&
	    $B/pm-balance -q -f -o "$tmp/md.pmap" "$tmp/md.shot" &&
	    $B/pm-render -q -f -D max_depth=$md --spp 64 --size 32x32 -o "$tmp/md-pm.exr" \
	        data/cornell-box.xml "$tmp/md.pmap" 2>"$tmp/md.err" &&
	    $B/pm-render -q -f -D max_depth=$md --spp 1024 --size 32x32 -o "$tmp/md-path.exr" \
	        data/cornell-box.xml; then
		set -- $($U relmse "$tmp/md-pm.exr" "$tmp/md-path.exr")
		echo "# cornell-box, max_depth $md: photon map against path tracing: mean R $2 G $3 B $4"
		check "max_depth $md: means within 2% of path tracing" sh -c \
		    "awk 'BEGIN { exit !($2^2 < 4e-4 && $3^2 < 4e-4 && $4^2 < 4e-4) }'"
	else
		check "max_depth $md renders" false
	fi
done
# A map shot without the limit is seen to be wrong for it.
$B/pm-shoot -q -f --seed 5 --photons 100000 -o "$tmp/nolimit.shot" data/cornell-box.xml &&
    $B/pm-balance -q -f -o "$tmp/nolimit.pmap" "$tmp/nolimit.shot"
check "a map shot for another max_depth gets one warning" sh -c \
    "$B/pm-render -D max_depth=3 --spp 1 --size 4x4 -o $tmp/w.exr data/cornell-box.xml $tmp/nolimit.pmap 2>$tmp/w.err && test \$(wc -l <$tmp/w.err) -eq 1 && grep -q 'photon bounces: no limit in the map, 1 for the scene' $tmp/w.err"

# Bias falls as photons grow: 20k against 500k global photons, the global
# map shown directly (fixed k and radius: the map's own bias, without the
# smoothing of final gathering), each against the reference of agree().
if map data/cornell-box.xml few 20000 0 && map data/cornell-box.xml many 500000 0 &&
    $B/pm-render -q --spp 8 --size 64x64 --direct-samples 4 --lookup-size 50 \
        --no-final-gather -o "$tmp/few.exr" data/cornell-box.xml "$tmp/few.pmap" &&
    $B/pm-render -q --spp 8 --size 64x64 --direct-samples 4 --lookup-size 50 \
        --no-final-gather -o "$tmp/many.exr" data/cornell-box.xml "$tmp/many.pmap"; then
	few=$($U relmse "$tmp/few.exr" "$tmp/cornell-box-path.exr" | cut -d' ' -f1)
	many=$($U relmse "$tmp/many.exr" "$tmp/cornell-box-path.exr" | cut -d' ' -f1)
	echo "# cornell-box relMSE: 20k photons $few, 500k photons $many"
	check "error falls as photons grow (20k -> 500k)" less "$many" "$few"
else
	check "bias renders" false
fi

finish agreement
