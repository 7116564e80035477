#!/bin/sh
# Progressive photon mapping through pm-render's --pass, --radius and
# --alpha: usage errors, the radius schedule printed by -v against
# Knaus and Zwicker's recurrence computed here with awk, --radius keeping
# the ratio of the two radii, and the mean of independent passes (each its
# own map and seed) converging on a path-traced reference of the same view:
# far closer than any single pass.
# Run from the repository root: sh tests/cli/progressive.sh
. tests/harness.sh
B=$BIN
X=$EXRUTIL
scene=data/cornell-box.xml

# radii PASS [options]: "scale global caustic" from pm-render -v
radii() {
	_p=$1
	shift
	$B/pm-render -f -v --pass "$_p" "$@" --spp 1 --size 4x4 -o "$tmp/r.exr" \
	    $scene "$tmp/m1.pmap" 2>&1 |
	    sed -n 's/.*radius scale \([^,]*\), fixed radii \([^ ]*\) (global) and \([^ ]*\) (caustic).*/\1 \2 \3/p'
}
# schedule PASS ALPHA: the radius scale by the recurrence
schedule() {
	awk -v p="$1" -v a="$2" 'BEGIN { s = 1; for (i = 1; i < p; i++) s *= (i + a) / (i + 1); printf "%.9g\n", sqrt(s) }'
}
close() { # a b tol: |a/b - 1| < tol
	awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { exit !(b != 0 && (a / b - 1) ^ 2 < t * t) }'
}

$B/pm-shoot -q -f --seed 1 --photons 20000 -o - $scene | $B/pm-balance -q -f -o "$tmp/m1.pmap" -
check "a map to render from" test -s "$tmp/m1.pmap"
check "--pass 0 exits 2" status 2 $B/pm-render --pass 0 -o "$tmp/x.exr" $scene "$tmp/m1.pmap"
check "--alpha 1 exits 2" status 2 $B/pm-render --pass 2 --alpha 1 -o "$tmp/x.exr" $scene "$tmp/m1.pmap"
check "--radius -1 exits 2" status 2 $B/pm-render --radius -1 -o "$tmp/x.exr" $scene "$tmp/m1.pmap"
check "--pass without a map exits 2" status 2 $B/pm-render --pass 2 -o "$tmp/x.exr" $scene

set -- $(radii 1)
g1=$2
c1=$3
check "pass 1 has scale 1" close "$1" 1 1e-9
for a in 0.5 0.6666666667 0.9; do
	for p in 2 3 7 50; do
		set -- $(radii $p --alpha $a)
		want=$(schedule $p $a)
		check "pass $p, alpha $a: scale $1 is the schedule's $want" close "$1" "$want" 1e-6
		check "...and both radii shrink by it" sh -c \
		    "awk -v g=$2 -v c=$3 -v g1=$g1 -v c1=$c1 -v s=$want 'BEGIN { exit !((g / (g1 * s) - 1)^2 < 1e-10 && (c / (c1 * s) - 1)^2 < 1e-10) }'"
	done
done
set -- $(radii 3 --alpha 0.5 --radius 0.1)
check "--radius sets the first global radius, keeping the caustic ratio" sh -c \
    "awk -v g=$2 -v c=$3 -v g1=$g1 -v c1=$c1 -v s=$(schedule 3 0.5) 'BEGIN { exit !((g / (g1 * 2 * s) - 1)^2 < 1e-10 && (c / (c1 * 2 * s) - 1)^2 < 1e-10) }'"

# 32 passes at the defaults, each its own map and seed (pm-balance and
# pm-render both told the pass), against a path-traced reference whose own
# noise is far below the errors compared: the running mean must converge,
# 8 passes at least twice and 32 passes at least four times closer than a
# single pass is on average.
$B/pm-render -q --spp 4096 --size 32x32 -o "$tmp/ref.exr" $scene
sum=0
i=1
while [ $i -le 32 ]; do
	$B/pm-shoot -q -f --seed $i --photons 20000 -o - $scene |
	    $B/pm-balance -q -f --pass $i -o "$tmp/m.pmap" - &&
	    $B/pm-render -q --seed $i --pass $i --spp 2 --size 32x32 \
	    -o "$tmp/p$i.exr" $scene "$tmp/m.pmap"
	e=$($X relmse "$tmp/p$i.exr" "$tmp/ref.exr" | cut -d' ' -f1)
	sum=$(awk -v a="$sum" -v b="${e:-1}" 'BEGIN { print a + b }')
	i=$((i + 1))
done
one=$(awk -v s="$sum" 'BEGIN { print s / 32 }')
$B/pm-downsample -q -o "$tmp/avg8.exr" $(i=1; while [ $i -le 8 ]; do printf '%s ' "$tmp/p$i.exr"; i=$((i + 1)); done)
$B/pm-downsample -q -o "$tmp/avg32.exr" "$tmp"/p*.exr
set -- $($X relmse "$tmp/avg8.exr" "$tmp/ref.exr")
check "the mean of 8 passes (relMSE $1) is at least 2x better than one pass ($one)" \
    awk -v a="$1" -v b="$one" 'BEGIN { exit !(a <= 0.5 * b) }'
set -- $($X relmse "$tmp/avg32.exr" "$tmp/ref.exr")
check "the mean of 32 passes (relMSE $1) is at least 4x better than one pass ($one)" \
    awk -v a="$1" -v b="$one" 'BEGIN { exit !(a <= 0.25 * b) }'
check "...and its mean is within 3% of the reference's" \
    awk -v r="$2" -v g="$3" -v b="$4" 'BEGIN { exit !(r^2 < 9e-4 && g^2 < 9e-4 && b^2 < 9e-4) }'

finish progressive
