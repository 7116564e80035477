#!/bin/sh
# range_vs.sh: fixed-radius queries per second of two commits' kd-trees,
# side by side on the same photons, queries and radii (the bench's range
# row, with any past commit as the reference).  From the repository root,
# after `make` (this tree's library writes the photons and radii):
#
#   sh tests/bench/range_vs.sh BEFORE AFTER SHOT.pmap [N [ROUNDS [TURNS]]]
#
# BEFORE and AFTER are commits (AFTER may be "." for the working tree);
# each one's common/kdtree.c is built alone with the same compiler flags
# into a walker (tests/bench/range_vs.c, -DRANGE_VS_WALK), which balances
# the first N (1000000) global photons of SHOT.pmap with that commit's
# build and times 20000 queries at the radii of the 50th and 200th
# neighbours, best of ROUNDS (3), one thread pinned to CPU 0; the two
# walkers run in turns, TURNS (3) times.  The issue-10 figure: BEFORE =
# 17fe3fd, where the issue was filed.
set -eu
[ $# -ge 3 ] || { echo "usage: sh tests/bench/range_vs.sh BEFORE AFTER SHOT.pmap [N [ROUNDS [TURNS]]]" >&2; exit 2; }
before=$1 after=$2 map=$3 n=${4:-1000000} rounds=${5:-3} turns=${6:-3}
CC=${CC:-cc}
FLAGS="-std=c17 -O2 -g -D_DEFAULT_SOURCE -fno-math-errno -pthread"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pm-range-vs-XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM

# The photons, queries and radii, by this tree's library.
$CC $FLAGS $(pkg-config --cflags OpenEXR 2>/dev/null) -I. -o "$tmp/dump" \
    tests/bench/range_vs.c build/libpm.a -lembree3 -lOpenEXRCore -lflann \
    $(pkg-config --libs expat libpng libjpeg zlib) -lm
"$tmp/dump" "$map" "$n" 20000 "$tmp/photons" 50 200

for c in "$before" "$after"; do
	d=$tmp/src-$(echo "$c" | tr -c 'A-Za-z0-9\n' _)
	mkdir -p "$d"
	if [ "$c" = . ]; then
		cp -R common "$d/"
	else
		git archive "$c" common | tar -x -C "$d"
	fi
	$CC $FLAGS -DRANGE_VS_WALK -I"$d" -o "$d/walk" tests/bench/range_vs.c \
	    "$d/common/kdtree.c" "$d/common/error.c" -lm
done
i=0
while [ "$i" -lt "$turns" ]; do
	for c in "$before" "$after"; do
		d=$tmp/src-$(echo "$c" | tr -c 'A-Za-z0-9\n' _)
		taskset -c 0 "$d/walk" "$tmp/photons" "$rounds" |
		    sed "s|^|$c: |"
	done
	i=$((i + 1))
done
