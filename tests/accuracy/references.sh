#!/bin/sh
# references.sh: long Mitsuba 3 renders of the scenes in data/, the ground
# truth of the accuracy study (pipelines/accuracy.mk, docs/accuracy.md).
#
#   sh tests/accuracy/references.sh [SCENE.xml...]     (default: data/*.xml)
#
# Run from the repository root. Mitsuba 3 comes from PyPI into build/venv
# (tests/mitsuba/setup-venv.sh: llvm_ad_rgb where it renders here, else
# scalar_rgb; the variant used is printed and kept in out/accuracy/ref/).
# Each scene is rendered with its own integrator (Mitsuba's `path`: the
# `ptracer` would see nothing through glass and mirrors, which every study
# scene shows to the camera) as two halves with different seeds,
# out/accuracy/ref/NAME-a.exr and NAME-b.exr: their mean is the reference,
# and their difference measures what noise is left in it, which the study
# subtracts from the error it measures.  Renders are cached in
# build/mitsuba-cache/ by a hash of the scene file, the files it names and
# the options (render_mitsuba.py --key-scope scene), so a second run costs
# nothing and only an edited scene is rendered again.  A scene Mitsuba
# cannot load (pm's extensions, such as MERL materials) is reported and
# skipped.
#
# Knobs (environment): REF_RES (128, the study's resolution), REF_SPP (spp
# per half for scenes without an entry below), REF_SPP_<name> (per scene,
# - as _), PM_VENV (build/venv).

set -u

RES=${REF_RES:-128}
VENV=${PM_VENV:-build/venv}
OUT=out/accuracy/ref
PY=$VENV/bin/python

if [ ! -f tests/mitsuba/render_mitsuba.py ]; then
	echo "references.sh: run me from the repository root" >&2
	exit 2
fi
mkdir -p "$OUT"
PM_VENV=$VENV sh tests/mitsuba/setup-venv.sh || {
	echo "references.sh: cannot set up Mitsuba 3 in $VENV" >&2
	exit 1
}
VARIANT=${MITSUBA_VARIANT:-$(cat "$VENV/pm-variant")}
echo "references: Mitsuba variant $VARIANT, ${RES}x${RES}"

# spp per half, chosen so that the study's error floor (the references' own
# noise) stays well below relMSE 0.001 on every study scene, so that the
# study can tell when pm or Mitsuba reaches it: caustics seen by a path
# tracer are fireflies, and so is what the camera sees through glass, so
# those scenes get the most (about 40 minutes in all on two cores with
# llvm_ad_rgb; cached once made).
spp_for() {
	case $1 in
	caustics) d=98304 ;;
	bunny-glass) d=16384 ;;
	cornell-box) d=3072 ;;
	bunny) d=4096 ;;
	spot-haze) d=16384 ;;
	*) d=${REF_SPP:-512} ;;
	esac
	v=$(eval "printf '%s' \"\${REF_SPP_$(printf '%s' "$1" | tr -c 'A-Za-z0-9\n' _):-}\"")
	printf '%s\n' "${v:-$d}"
}

[ $# -gt 0 ] || set -- data/*.xml
made=0
skipped=0
for scene in "$@"; do
	name=$(basename "$scene" .xml)
	spp=$(spp_for "$name")
	ok=1
	for half in a b; do
		seed=$([ $half = a ] && echo 101 || echo 102)
		if ! "$PY" tests/mitsuba/render_mitsuba.py "$scene" \
		    "$OUT/$name-$half.exr" --spp "$spp" -D "res=$RES" \
		    --seed "$seed" --variant "$VARIANT" --key-scope scene \
		    >"$OUT/$name-$half.log" 2>&1; then
			ok=0
			break
		fi
		cat "$OUT/$name-$half.log"
	done
	if [ $ok = 1 ]; then
		made=$((made + 1))
		printf '%s\t%s\t%s\t%s\n' "$name" "$RES" "$spp" "$VARIANT" \
		    >"$OUT/$name.txt"
	else
		skipped=$((skipped + 1))
		echo "references: $name: Mitsuba cannot render $scene; skipped" \
		    "($(tail -n 1 "$OUT/$name-$half.log"))"
		rm -f "$OUT/$name-a.exr" "$OUT/$name-b.exr" "$OUT/$name.txt"
	fi
done
echo "references: $made made or cached, $skipped skipped, in $OUT"
