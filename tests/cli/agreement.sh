#!/bin/sh
# The photon-map render agrees with the path-traced reference: on
# data/cornell-box.xml and data/caustics.xml the image means agree within 2%
# per channel, and the error against the reference falls as photons grow.
# Run from the repository root: sh tests/cli/agreement.sh
n=0
fail=0
B=${BIN:-bin}
U=${EXRUTIL:-build/tests/exrutil}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

check() {
	n=$((n + 1))
	desc=$1
	shift
	if "$@"; then echo "ok $n - $desc"; else echo "not ok $n - $desc"; fail=$((fail + 1)); fi
}
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

# Bias falls as photons grow: 20k against 500k global photons, fixed k and
# radius, each against the reference of agree() above.
if map data/cornell-box.xml few 20000 0 && map data/cornell-box.xml many 500000 0 &&
    $B/pm-render -q --spp 8 --size 64x64 --direct-samples 4 --lookup-size 50 \
        -o "$tmp/few.exr" data/cornell-box.xml "$tmp/few.pmap" &&
    $B/pm-render -q --spp 8 --size 64x64 --direct-samples 4 --lookup-size 50 \
        -o "$tmp/many.exr" data/cornell-box.xml "$tmp/many.pmap"; then
	few=$($U relmse "$tmp/few.exr" "$tmp/cornell-box-path.exr" | cut -d' ' -f1)
	many=$($U relmse "$tmp/many.exr" "$tmp/cornell-box-path.exr" | cut -d' ' -f1)
	echo "# cornell-box relMSE: 20k photons $few, 500k photons $many"
	check "error falls as photons grow (20k -> 500k)" less "$many" "$few"
else
	check "bias renders" false
fi

echo "agreement: $((n - fail)) passed, $fail failed"
[ "$fail" -eq 0 ]
