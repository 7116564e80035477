#!/bin/sh
# tests/cluster/merge-bench.sh: how pm-balance's time grows with the number
# of shards it merges (docs/cluster.md).  For K = 1, 2, 4, 8, 16 it
# balances K shards of data/bunny.xml holding a fixed TOTAL of photon
# paths (TOTAL/K each), then K shards of a fixed TOTAL/16 each (the total
# growing with K), then the 16 shards in two levels (4 groups of 4,
# balanced without irradiance records, then the 4 groups), and checks
# that the two levels give the flat merge's photons and records.
# Prints TSV: case, shards, paths, photons, wall s, CPU s (user+system),
# peak memory MB, and pm-balance -v's own sort, kd-tree and irradiance
# times for the global map.  Runs from the repository root; heavy.
#
#   nice -n 10 sh tests/cluster/merge-bench.sh [TOTAL [REPEAT]]
B=${BIN:-bin}
T=${1:-4000000}
R=${2:-2}
scene=data/bunny.xml
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# shoot K I SIZE: shard I (from 0) of K, SIZE paths of each kind
shoot() {
	$B/pm-shoot -q -f --photons "$3" --caustic-photons "$3" --first-index $(($2 * $3)) \
	    -o "$tmp/$1-$2.pmap" $scene || exit 1
}
# balance CASE SHARDS PATHS OUT IN...: times pm-balance, best wall of R runs
balance() {
	c=$1 k=$2 p=$3 out=$4
	shift 4
	best=
	r=0
	while [ $r -lt "$R" ]; do
		/usr/bin/time -f '%e %U %S %M' -o "$tmp/time" $B/pm-balance -f -v $BALANCE \
		    -o "$out" "$@" 2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
		set -- "$@"
		line=$(awk -v c="$c" -v k="$k" -v p="$p" '
		    FILENAME ~ /time$/ { wall = $1; cpu = $2 + $3; mb = $4 / 1024; next }
		    /global map: .* photons,/ {
			for (i = 1; i <= NF; i++) {
				if ($i == "photons,") n = $(i - 1)
				if ($i == "sorted") s = $(i + 2)
				if ($i == "built") t = $(i + 2)
			}
		    }
		    /irradiance map: / { for (i = 1; i <= NF; i++) if ($i == "in") irr = $(i + 1) }
		    END { printf "%s\t%d\t%d\t%d\t%.2f\t%.2f\t%.0f\t%s\t%s\t%s\n",
			c, k, p, n, wall, cpu, mb, s, t, irr == "" ? "-" : irr }' \
		    "$tmp/time" "$tmp/err")
		w=$(echo "$line" | cut -f5)
		if [ -z "$best" ] || awk -v a="$w" -v b="$(echo "$best" | cut -f5)" 'BEGIN { exit !(a < b) }'; then
			best=$line
		fi
		r=$((r + 1))
	done
	echo "$best"
}
records() { $B/pm-inspect "$1" | grep '^\(global\|caustic\|irradiance\)\.\(photons\|emitted\|records_crc32\)'; }

echo "# $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%Y-%m-%dT%H:%MZ)"
printf 'case\tshards\tpaths\tphotons\twall_s\tcpu_s\tmax_MB\tsort_s\ttree_s\tirradiance_s\n'
for k in 1 2 4 8 16; do
	i=0
	while [ $i -lt $k ]; do shoot f$k $i $((T / k)); i=$((i + 1)); done
	set --
	i=0
	while [ $i -lt $k ]; do set -- "$@" "$tmp/f$k-$i.pmap"; i=$((i + 1)); done
	balance fixed $k "$T" "$tmp/out.pmap" "$@"
	[ $k -eq 16 ] || rm -f "$tmp"/f$k-*.pmap
done
# The 16 shards of T/16 are the first K shards of the growing case.
for k in 1 2 4 8 16; do
	set --
	i=0
	while [ $i -lt $k ]; do set -- "$@" "$tmp/f16-$i.pmap"; i=$((i + 1)); done
	balance growing $k $((k * T / 16)) "$tmp/flat.pmap" "$@"
done
g=0
while [ $g -lt 4 ]; do
	i=$((4 * g))
	BALANCE=--irradiance-stride=0 balance group $((4)) $((T / 4)) "$tmp/g$g.pmap" \
	    "$tmp/f16-$i.pmap" "$tmp/f16-$((i + 1)).pmap" "$tmp/f16-$((i + 2)).pmap" "$tmp/f16-$((i + 3)).pmap"
	g=$((g + 1))
done
balance groups 4 "$T" "$tmp/two.pmap" "$tmp/g0.pmap" "$tmp/g1.pmap" "$tmp/g2.pmap" "$tmp/g3.pmap"
if [ "$(records "$tmp/two.pmap")" = "$(records "$tmp/flat.pmap")" ]; then
	echo "# two levels: the flat merge's photons and records"
else
	echo "# two levels: NOT the flat merge's photons and records"
	exit 1
fi
