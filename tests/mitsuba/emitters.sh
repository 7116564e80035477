#!/bin/sh
# emitters.sh: check pm's envmap, directional, textured and projector
# emitters (and the textures they brought: rawconstant, RGBE bitmaps,
# textures within a checkerboard, textured glass, mesh_attribute) against
# Mitsuba 3, in path mode and in photon mode.
#
#   sh tests/mitsuba/emitters.sh
#
# Run from the repository root.  tests/mitsuba/emitter_scenes.py writes
# the scenes and their environment maps (made here, never downloaded)
# into build/mitsuba-out/emitters/; each is rendered twice by Mitsuba (the
# scene's path integrator, cached as compare.sh's are) and twice by pm:
# pm-render's path tracer, and the photon pipeline (pm-shoot, pm-balance,
# pm-render --method photon); compare.py judges each pair.  envmap-flat
# is a one-colour map, which must light as Mitsuba's constant does: it is
# compared with Mitsuba's render of the same scene with that constant.
# TAP-like lines and "mitsuba emitters: N passed, N failed"; the exit
# status is non-zero when anything failed.
#
# Knobs (environment) as compare.sh: MITSUBA_RES (256), MITSUBA_SPP (256),
# PM_SPP (64), PM_PHOTONS (200000 global photon paths), PM_VENV, ...

set -u

RES=${MITSUBA_RES:-256}
MI_SPP=${MITSUBA_SPP:-256}
PM_SPP=${PM_SPP:-64}
PHOTONS=${PM_PHOTONS:-200000}
B=${PM_BIN:-bin}
OUT=build/mitsuba-out
DIR=$OUT/emitters
VENV=${PM_VENV:-build/venv}
PY=$VENV/bin/python
HERE=tests/mitsuba

. tests/harness.sh
diag() { sed 's/^/# /'; }

if [ ! -f "$HERE/compare.py" ]; then
	echo "emitters.sh: run me from the repository root" >&2
	exit 2
fi
mkdir -p "$OUT"
if ! PM_VENV=$VENV sh "$HERE/setup-venv.sh" >"$OUT/setup.log" 2>&1; then
	diag <"$OUT/setup.log"
	check "set up Mitsuba 3 in $VENV (pip install mitsuba numpy)" false
	finish "mitsuba emitters"
	exit
fi
VARIANT=${MITSUBA_VARIANT:-$(cat "$VENV/pm-variant")}

if ! "$PY" "$HERE/emitter_scenes.py" "$DIR" >"$OUT/log" 2>&1; then
	diag <"$OUT/log"
	check "emitter_scenes.py writes the scenes" false
	finish "mitsuba emitters"
	exit
fi

# mitsuba SCENE SEED: $DIR/SCENE-mi-SEED.exr
mitsuba() {
	"$PY" "$HERE/render_mitsuba.py" "$DIR/$1.xml" "$DIR/$1-mi-$2.exr" \
	    --spp "$MI_SPP" -D "res=$RES" --seed "$2" --variant "$VARIANT" \
	    --key-scope scene ${MITSUBA_RECORD:+--record "$MITSUBA_RECORD"} \
	    >"$OUT/log" 2>&1
	_rc=$?
	diag <"$OUT/log"
	return $_rc
}

# pmpath SCENE SEED: $DIR/SCENE-path-SEED.exr
pmpath() {
	$B/pm-render "$DIR/$1.xml" -o "$DIR/$1-path-$2.exr" --spp "$PM_SPP" \
	    -D "res=$RES" --seed "$2" -q -f >"$OUT/log" 2>&1
	_rc=$?
	diag <"$OUT/log"
	return $_rc
}

# pmphoton SCENE SEED: photon map, then $DIR/SCENE-photon-SEED.exr
pmphoton() {
	$B/pm-shoot -q -f --photons "$PHOTONS" --seed "$2" \
	    -o "$DIR/$1-$2.shot" "$DIR/$1.xml" >"$OUT/log" 2>&1 &&
	$B/pm-balance -q -f -o "$DIR/$1-$2.pmap" "$DIR/$1-$2.shot" \
	    >>"$OUT/log" 2>&1 &&
	$B/pm-render --method photon "$DIR/$1.xml" "$DIR/$1-$2.pmap" \
	    -o "$DIR/$1-photon-$2.exr" --spp "$PM_SPP" -D "res=$RES" \
	    --seed "$2" -q -f >>"$OUT/log" 2>&1
	_rc=$?
	diag <"$OUT/log"
	return $_rc
}

# compare NAME REF MODE: compare.py of REF's Mitsuba pair against pm's
compare() {
	"$PY" "$HERE/compare.py" "$DIR/$2-mi-1.exr" "$DIR/$1-$3-1.exr" \
	    --a2 "$DIR/$2-mi-2.exr" --b2 "$DIR/$1-$3-2.exr" --name "$1-$3" \
	    --diff "$DIR/$1-$3-diff.exr" >"$DIR/$1-$3.txt" 2>&1
	_rc=$?
	diag <"$DIR/$1-$3.txt"
	return $_rc
}

# against NAME REF [MODES]: pm's modes (path and photon) on NAME against
# Mitsuba's render of REF
against() {
	if ! mitsuba "$2" 1 || ! mitsuba "$2" 2; then
		check "$1: Mitsuba cannot render $2.xml" false
		return
	fi
	for mode in ${3:-path photon}; do
		if ! pm$mode "$1" 1 || ! pm$mode "$1" 2; then
			check "$1: pm fails in $mode mode" false
			continue
		fi
		if compare "$1" "$2" "$mode"; then
			check "$1: pm ($mode) agrees with Mitsuba ($RES x $RES, Mitsuba 2x$MI_SPP spp, pm 2x$PM_SPP spp)" true
		else
			check "$1: pm ($mode) differs from Mitsuba (see $DIR/$1-$mode.txt)" false
		fi
	done
}

t0=$(date +%s)
echo "# Mitsuba variant $VARIANT, ${RES}x${RES}"
against envmap envmap
against envmap-glass envmap-glass
# Seen directly there is nothing to gather: path mode says it all.
against envmap-view envmap-view path
against envmap-view-hdr envmap-view-hdr path
against envmap-view-png envmap-view-png path
# The flat map against Mitsuba's constant emitter of the same colour.
sed 's|<emitter type="envmap">|<emitter type="constant">|; s|<string name="filename" value="flat.exr"/>|<rgb name="radiance" value="0.6, 0.7, 0.9"/>|' \
    "$DIR/envmap-flat.xml" >"$DIR/constant.xml"
against envmap-flat constant
against directional directional
# Light selection with an environment: a small spot under a dim map.
against spot-envmap spot-envmap path
if "$PY" "$HERE/variance.py" "$DIR/spot-envmap-mi-1.exr" \
    "$DIR/spot-envmap-mi-2.exr" "$MI_SPP" "$DIR/spot-envmap-path-1.exr" \
    "$DIR/spot-envmap-path-2.exr" "$PM_SPP" >"$OUT/log" 2>&1; then
	_ok=true
else
	_ok=false
fi
diag <"$OUT/log"
check "spot-envmap: pm's variance per sample is within 2x Mitsuba's" $_ok
# Textured emitters (a spot's texture, the projector with a bitmap and
# with a colour, bitmap and checkerboard radiance on area lights) and the
# textures of tex-more.xml (an RGBE bitmap and rawconstants in a
# checkerboard, textured glass).
for scene in spot-tex projector projector-flat area-tex tex-more \
    mesh-attr; do
	against $scene $scene
done
# A light's radiance from its mesh's vertex colours: direct light only,
# against Mitsuba's BSDF samples alone (see emitter_scenes.py).
against mesh-attr-lamp mesh-attr-lamp-ref path
echo "# total $(($(date +%s) - t0)) s"
finish "mitsuba emitters"
