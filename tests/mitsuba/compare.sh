#!/bin/sh
# compare.sh: check pm-render against Mitsuba 3 on the same scene files.
#
#   sh tests/mitsuba/compare.sh              pm-render versus Mitsuba
#   sh tests/mitsuba/compare.sh --selftest   Mitsuba versus itself, to prove
#                                            the comparison can pass and fail
#
# Run from the repository root. Each scene is rendered twice by each renderer
# with different seeds (the second render tells compare.py how noisy each side
# is); Mitsuba's renders are cached under build/mitsuba-cache/, so after the
# first run only pm-render's cost remains. Outputs land in build/mitsuba-out/.
# The scenes: data/cornell-box.xml and the others of data/ listed below
# (ours, must exist; fog-box, glass-medium, spot-haze and smoke have
# media, all four and hetero-box checked in path and photon mode),
# Mitsuba's own
# Cornell box from ../shared/scenes/mitsuba-cbox (skipped when ../shared is
# absent), data/principled.xml (path traced and photon-mapped, after the
# principled BSDFs point by point), tests/mitsuba/textures.xml and
# tests/mitsuba/frames.xml (path
# traced and photon-mapped) and
# the scenes tests/mitsuba/shapes_scene.py writes (shapes and sensors, path
# traced and photon-mapped), cornell-box, sky and point-lights under
# Mitsuba's particle tracer (ptracer), cornell-box under the moment
# integrator (the variance channel), tests/mitsuba/composite.xml and
# conductors.xml (blendbsdf, mask, two-faced twosided; named conductors;
# path traced and photon-mapped).
# Results are TAP-like lines and a closing "mitsuba cli: N passed,
# N failed"; the exit status is non-zero when anything failed, including
# the set-up of Mitsuba itself (no network means failure, never a pass).
#
# Knobs (environment): MITSUBA_RES (256), MITSUBA_SPP (256, per Mitsuba
# render), PM_SPP (64, per pm-render render), PM_RENDER (bin/pm-render),
# PM_SHOOT (bin/pm-shoot), PM_BALANCE (bin/pm-balance) and PM_PHOTONS
# (1000000 global and as many caustic photon paths per map) for the
# photon-mapped renders, PM_THREADS (pm-render's -t, unset: its default),
# MEDIA_PHOTON_SPP (pm-render's spp for the media scenes in photon
# mode, PM_SPP / 4 unset, 64 for spot-haze),
# SPOT_RES (128), SPOT_MITSUBA_SPP (4096) and SPOT_PM_SPP (1024, path
# mode) for spot-haze,
# MITSUBA_VARIANT, PM_VENV (build/venv), SMOKE_MITSUBA_SPP (smoke's
# Mitsuba spp, MITSUBA_SPP unset), MITSUBA_ONLY (the checks to run,
# by the names the results give them, separated by spaces, e.g. "fog-box
# texture-lookups"; unset: all).

set -u

RES=${MITSUBA_RES:-256}
MI_SPP=${MITSUBA_SPP:-256}
PM_SPP=${PM_SPP:-64}
PM_RENDER=${PM_RENDER:-bin/pm-render}
PM_SHOOT=${PM_SHOOT:-bin/pm-shoot}
PM_BALANCE=${PM_BALANCE:-bin/pm-balance}
PM_PHOTONS=${PM_PHOTONS:-1000000}
PM_MAP=			# set by pmphoton only
OUT=build/mitsuba-out
VENV=${PM_VENV:-build/venv}
PY=$VENV/bin/python
HERE=tests/mitsuba

selftest=0
case "${1:-}" in
--selftest) selftest=1 ;;
"") ;;
*) echo "usage: sh tests/mitsuba/compare.sh [--selftest]" >&2; exit 2 ;;
esac

. tests/harness.sh
diag() { sed 's/^/# /'; }

if [ ! -f "$HERE/compare.py" ]; then
	echo "compare.sh: run me from the repository root" >&2
	exit 2
fi

mkdir -p "$OUT"
if PM_VENV=$VENV sh "$HERE/setup-venv.sh" >"$OUT/setup.log" 2>&1; then
	diag <"$OUT/setup.log"
else
	diag <"$OUT/setup.log"
	check "set up Mitsuba 3 in $VENV (pip install mitsuba numpy)" false
	finish mitsuba
	exit
fi
VARIANT=${MITSUBA_VARIANT:-$(cat "$VENV/pm-variant")}

now() { date +%s; }

# mitsuba NAME TAG SCENE SPP SEED [render_mitsuba options]: one Mitsuba
# render to $OUT/NAME-TAG.exr; its log goes to the TAP diagnostics.
# MI_DEFINES (name=value ..., empty but for smoke) are Mitsuba's alone.
MI_DEFINES=
mitsuba() {
	_out=$OUT/$1-$2.exr
	_scene=$3
	_spp=$4
	_seed=$5
	shift 5
	for _d in $MI_DEFINES; do
		set -- "$@" -D "$_d"
	done
	"$PY" "$HERE/render_mitsuba.py" "$_scene" "$_out" --spp "$_spp" \
	    -D "res=$RES" --seed "$_seed" --variant "$VARIANT" \
	    --key-scope scene ${MITSUBA_RECORD:+--record "$MITSUBA_RECORD"} \
	    "$@" >"$OUT/log" 2>&1
	_rc=$?
	diag <"$OUT/log"
	return $_rc
}

# pmrender NAME SCENE SEED: one pm-render render to $OUT/NAME-pm-SEED.exr;
# with PM_MAP set (pmphoton), by photon mapping from that map, every camera
# sample gathering for itself: the image-space irradiance cache
# (--cache-step) shares gathers between pixels, which the per-block test
# sees as bias (at 256x256 and 64 spp, 0.9% of rough.xml's blocks beyond
# 4 sigma, 0.5% of materials.xml's, 1.2% to 2.5% of cornell-box.xml's;
# without it 0.0%, 0.0% and 0.0% to 0.1%).
pmrender() {
	_t0=$(now)
	_seed=$3
	set -- "$2" -o "$OUT/$1-pm-$3.exr" --spp "$PM_SPP" \
	    --size "${RES}x${RES}" -D "res=$RES" --seed "$3" -q -f
	[ -n "${PM_THREADS:-}" ] && set -- "$@" -t "$PM_THREADS"
	[ -n "${PM_MAP:-}" ] && set -- "$@" --cache-step 0 "$PM_MAP"
	"$PM_RENDER" "$@" >"$OUT/log" 2>&1
	_rc=$?
	tail -n 20 "$OUT/log" | diag
	echo "pm-render: $1 seed $_seed spp $PM_SPP in $(($(now) - _t0)) s (exit $_rc)" |
	    diag
	return $_rc
}

# pmphoton NAME SCENE SEED: pm-shoot and pm-balance a photon map with the
# seed, then pmrender with it (photon mapping).
pmphoton() {
	_map=$OUT/$1-$3.pmap
	if ! "$PM_SHOOT" -q -f --seed "$3" --photons "$PM_PHOTONS" \
	    --caustic-photons "$PM_PHOTONS" -D "res=$RES" -o "$_map.shot" "$2" \
	    >"$OUT/log" 2>&1 ||
	    ! "$PM_BALANCE" -q -f -o "$_map" "$_map.shot" >>"$OUT/log" 2>&1; then
		diag <"$OUT/log"
		return 1
	fi
	# not as a prefix assignment: whether one outlives a function call
	# is up to the shell
	PM_MAP=$_map
	pmrender "$@"
	_rc=$?
	PM_MAP=
	return $_rc
}

# compare NAME WHAT A A2 B B2: runs compare.py; 0 when it passed.
compare() {
	"$PY" "$HERE/compare.py" "$3" "$5" --a2 "$4" --b2 "$6" \
	    --name "$1" --diff "$OUT/$1-$2-diff.exr" >"$OUT/$1-$2.txt" 2>&1
	_rc=$?
	diag <"$OUT/$1-$2.txt"
	return $_rc
}

# against NAME SCENE [photon]: pm-render (path tracing, or with "photon"
# photon mapping from a map shot here) against Mitsuba.
against() {
	name=$1
	scene=$2
	render=pmrender
	[ "${3:-}" = photon ] && render=pmphoton
	if ! mitsuba "$name" mi-1 "$scene" "$MI_SPP" 1 ||
	    ! mitsuba "$name" mi-2 "$scene" "$MI_SPP" 2; then
		check "$name: Mitsuba cannot render $scene" false
		return
	fi
	if [ ! -x "$PM_RENDER" ]; then
		check "$name: $PM_RENDER not built" false
		return
	fi
	if ! $render "$name" "$scene" 1; then
		check "$name: pm-render failed on $scene" false
		return
	fi
	if ! $render "$name" "$scene" 2; then
		check "$name: pm-render failed on $scene" false
		return
	fi
	if compare "$name" vs "$OUT/$name-mi-1.exr" "$OUT/$name-mi-2.exr" \
	    "$OUT/$name-pm-1.exr" "$OUT/$name-pm-2.exr"; then
		check "$name: pm-render agrees with Mitsuba ($RES x $RES, Mitsuba 2x$MI_SPP spp, pm-render 2x$PM_SPP spp)" true
	else
		check "$name: pm-render differs from Mitsuba (see build/mitsuba-out/$name-vs.txt, $name-vs-diff.exr)" false
	fi
}

# moments NAME SCENE: a scene under Mitsuba's moment integrator; the
# variance of one sample, m2 - m1^2 of the moment channels, from Mitsuba
# (render_mitsuba.py --moments) against pm-render's channels (moments.py),
# compared as images are.
moments() {
	name=$1
	scene=$2
	if ! mitsuba "$name" mi-1 "$scene" "$MI_SPP" 1 --moments ||
	    ! mitsuba "$name" mi-2 "$scene" "$MI_SPP" 2 --moments; then
		check "$name: Mitsuba cannot render $scene" false
		return
	fi
	for _s in 1 2; do
		if ! pmrender "$name" "$scene" $_s ||
		    ! "$PY" "$HERE/moments.py" "$OUT/$name-pm-$_s.exr" \
		    "$OUT/$name-pmvar-$_s.exr" >"$OUT/log" 2>&1; then
			diag <"$OUT/log"
			check "$name: pm-render's moments failed on $scene" false
			return
		fi
	done
	if compare "$name" vs "$OUT/$name-mi-1.exr" "$OUT/$name-mi-2.exr" \
	    "$OUT/$name-pmvar-1.exr" "$OUT/$name-pmvar-2.exr"; then
		check "$name: pm-render's variance (m2 - m1^2) agrees with Mitsuba's moment integrator" true
	else
		check "$name: pm-render's variance differs from Mitsuba's (see build/mitsuba-out/$name-vs.txt)" false
	fi
}

# selfcheck NAME SCENE: Mitsuba against itself must pass with other seeds
# and fail, on the mean check, with a light 5% brighter.
selfcheck() {
	name=$1
	scene=$2
	if ! mitsuba "$name" mi-1 "$scene" "$MI_SPP" 1 ||
	    ! mitsuba "$name" mi-2 "$scene" "$MI_SPP" 2 ||
	    ! mitsuba "$name" self-3 "$scene" "$PM_SPP" 3 ||
	    ! mitsuba "$name" self-4 "$scene" "$PM_SPP" 4 ||
	    ! mitsuba "$name" bright-3 "$scene" "$PM_SPP" 3 --light-scale 1.05 ||
	    ! mitsuba "$name" bright-4 "$scene" "$PM_SPP" 4 --light-scale 1.05
	then
		check "$name: Mitsuba cannot render $scene" false
		return
	fi
	if compare "$name" self "$OUT/$name-mi-1.exr" "$OUT/$name-mi-2.exr" \
	    "$OUT/$name-self-3.exr" "$OUT/$name-self-4.exr"; then
		check "$name: Mitsuba agrees with itself under other seeds" true
	else
		check "$name: Mitsuba disagrees with itself under other seeds" false
	fi
	if compare "$name" bright "$OUT/$name-mi-1.exr" "$OUT/$name-mi-2.exr" \
	    "$OUT/$name-bright-3.exr" "$OUT/$name-bright-4.exr"; then
		check "$name: a light 5% brighter went unnoticed" false
	elif grep -q ' mean *FAIL' "$OUT/$name-bright.txt"; then
		check "$name: a light 5% brighter fails the mean check" true
	else
		check "$name: a light 5% brighter failed, but not the mean check" false
	fi
}

# wanted NAME: whether MITSUBA_ONLY (unset: everything) names NAME.
wanted() {
	case " ${MITSUBA_ONLY:-$1} " in
	*" $1 "*) return 0 ;;
	esac
	return 1
}

run() {
	wanted "$1" || return 0
	if [ "$selftest" = 1 ]; then
		selfcheck "$@"
	else
		against "$@"
	fi
}

t0=$(now)
echo "# Mitsuba variant $VARIANT, ${RES}x${RES}"

if [ -f data/cornell-box.xml ]; then
	run cornell-box data/cornell-box.xml
else
	check "cornell-box: data/cornell-box.xml is missing" false
fi

if [ -f data/materials.xml ]; then
	run materials data/materials.xml
else
	check "materials: data/materials.xml is missing" false
fi

for scene in point-lights sky bunny; do
	if [ -f data/$scene.xml ]; then
		run $scene data/$scene.xml
	else
		check "$scene: data/$scene.xml is missing" false
	fi
done

# The rough metals of materials.xml under Mitsuba's default distribution,
# Beckmann's, instead of GGX.
if [ -f data/materials.xml ]; then
	sed 's|<string name="distribution" value="ggx"/>|<string name="distribution" value="beckmann"/>|' \
	    data/materials.xml >"$OUT/materials-beckmann.xml"
	run materials-beckmann "$OUT/materials-beckmann.xml"
fi

# Mitsuba's direct integrator, which pm renders as the path tracer to
# depth 2: the box under Mitsuba's own direct against pm's reading of it.
if [ -f data/cornell-box.xml ]; then
	sed 's|<integrator type="path">|<integrator type="direct">|; /name="max_depth"/d' \
	    data/cornell-box.xml >"$OUT/cornell-direct.xml"
	run cornell-direct "$OUT/cornell-direct.xml"
fi

# Participating media, under Mitsuba's volpath: fog filling the box and
# the camera's surroundings, and a glass ball holding a medium.  Then two
# variants, written to a folder of their own (they name no other files,
# so Mitsuba's cached renders of them stay valid): the fog to max_depth 2
# (direct light and single scattering: how scatters count as bounces),
# and the ball's medium behind a null surface (light sampled through an
# index-matched boundary; crossing it is no bounce).
for scene in fog-box glass-medium; do
	if [ -f data/$scene.xml ]; then
		run $scene data/$scene.xml
	else
		check "$scene: data/$scene.xml is missing" false
	fi
done
# The same in photon mode (the volume photon map).
# Every camera sample gathers here (no irradiance cache in media), so
# pm-render takes a quarter of PM_SPP (MEDIA_PHOTON_SPP overrides): its
# two renders still tell compare.py how noisy they are.
_pm_spp=$PM_SPP
PM_SPP=${MEDIA_PHOTON_SPP:-$(( PM_SPP / 4 > 0 ? PM_SPP / 4 : 1 ))}
for scene in fog-box glass-medium; do
	[ -f data/$scene.xml ] && [ "$selftest" = 0 ] &&
	    wanted $scene-photon && against $scene-photon data/$scene.xml photon
done
PM_SPP=$_pm_spp
# The glass ball under a snooted area light in haze (data/spot-haze.xml),
# in path and photon mode: the volumetric caustic.  A path tracer finds
# the lamp through the ball only by chance, so Mitsuba's volpath (and
# pm's path mode) see the caustics as fireflies: at 256x256 and 256 spp
# they failed the block test in every dim block that held one.  So this
# scene is checked at 128x128 (SPOT_RES) with 4096 spp per Mitsuba render
# (SPOT_MITSUBA_SPP), pm's path mode with 1024 (SPOT_PM_SPP) and its
# photon mode with MEDIA_PHOTON_SPP (64 unset); the photon check reuses
# the path check's Mitsuba renders (the cache).
if [ -f data/spot-haze.xml ]; then
	_res=$RES _mi_spp=$MI_SPP _pm_spp=$PM_SPP
	RES=${SPOT_RES:-128}
	MI_SPP=${SPOT_MITSUBA_SPP:-4096}
	PM_SPP=${SPOT_PM_SPP:-1024}
	run spot-haze data/spot-haze.xml
	PM_SPP=${MEDIA_PHOTON_SPP:-64}
	[ "$selftest" = 0 ] && wanted spot-haze-photon &&
	    against spot-haze-photon data/spot-haze.xml photon
	RES=$_res MI_SPP=$_mi_spp PM_SPP=$_pm_spp
elif wanted spot-haze || wanted spot-haze-photon; then
	check "spot-haze: data/spot-haze.xml is missing" false
fi
VARIANTS=build/mitsuba-variants
mkdir -p "$VARIANTS"
if [ -f data/fog-box.xml ]; then
	sed 's|<default name="max_depth" value="-1"/>|<default name="max_depth" value="2"/>|' \
	    data/fog-box.xml >"$VARIANTS/fog-single.xml"
	run fog-single "$VARIANTS/fog-single.xml"
fi
if [ -f data/glass-medium.xml ]; then
	sed 's|<bsdf type="dielectric">|<bsdf type="null">|; /name="int_ior"/d' \
	    data/glass-medium.xml >"$VARIANTS/haze-ball.xml"
	run haze-ball "$VARIANTS/haze-ball.xml"
fi

# Heterogeneous media: smoke from a grid (data/smoke.xml; `make` writes
# its grids), and fog-box's fog as a constant RGB grid volume
# (heterogeneous, delta tracking against a majorant, the camera inside it)
# where fog-box has it homogeneous.
# Mitsuba renders smoke with the medium's sample_emitters off: its
# volpath's light samples from points of a medium within a few tenths of
# the light, whose shadow rays leave through a null boundary, come out
# far too dark (data/smoke.xml's plume top, 0.24 under the light: 10x in
# a homogeneous test box, against quadrature: null_box_nee.py and
# docs/media.md), while its phase-function sampling alone agrees with
# quadrature and with pm.
# pm-render keeps its light samples (the scene's default).  Without them
# Mitsuba's smoke also renders faster: 2x64 spp at 256x256 in 72 s and
# 54 s (2026-12-03), where with them it took 268 s and 473 s, its shadow
# rays tracked through the grid against its largest value.
# SMOKE_MITSUBA_SPP sets its spp apart (MITSUBA_SPP unset).
if [ -f data/smoke.xml ] && [ -f data/smoke.vol ]; then
	_mi_spp=$MI_SPP
	MI_SPP=${SMOKE_MITSUBA_SPP:-$MI_SPP}
	MI_DEFINES=sample_emitters=false
	run smoke data/smoke.xml
	MI_DEFINES=
	MI_SPP=$_mi_spp
elif wanted smoke; then
	check "smoke: data/smoke.xml or its grid (make data/smoke.vol) is missing" false
fi
if [ -f data/fog-box.xml ] && { wanted hetero-box || wanted hetero-box-photon; }; then
	if build/tests/volgen const "$VARIANTS/fog-const.vol" 2 2 2 0.3 0.4 0.5; then
		sed 's|<medium type="homogeneous" id="fog">|<medium type="heterogeneous" id="fog">|
		    s|<rgb name="sigma_t" value="0.3, 0.4, 0.5"/>|<volume type="gridvolume" name="sigma_t"><string name="filename" value="fog-const.vol"/><transform name="to_world"><scale x="2.4" y="2.4" z="5.6"/><translate x="-1.2" y="-0.2" z="-1.2"/></transform></volume>|' \
		    data/fog-box.xml >"$VARIANTS/hetero-box.xml"
		run hetero-box "$VARIANTS/hetero-box.xml"
	else
		check "hetero-box: build/tests/volgen not built (make build/tests/volgen)" false
	fi
fi
# The same two in photon mode: photons delta-tracked through the grid and
# stored at real scatters, camera segments with delta-tracked points and
# ratio-tracked transmittance (integrator_pmvol.c), at pm-render's spp of
# fog-box-photon (MEDIA_PHOTON_SPP); Mitsuba's renders are the path-mode
# checks' own (the same files, spp and seeds: its cache holds them).
if [ "$selftest" = 0 ]; then
	_pm_spp=$PM_SPP
	PM_SPP=${MEDIA_PHOTON_SPP:-$(( PM_SPP / 4 > 0 ? PM_SPP / 4 : 1 ))}
	if [ -f data/smoke.xml ] && [ -f data/smoke.vol ] &&
	    wanted smoke-photon; then
		_mi_spp=$MI_SPP
		MI_SPP=${SMOKE_MITSUBA_SPP:-$MI_SPP}
		MI_DEFINES=sample_emitters=false	# as for smoke, above
		against smoke-photon data/smoke.xml photon
		MI_DEFINES=
		MI_SPP=$_mi_spp
	fi
	[ -f "$VARIANTS/hetero-box.xml" ] && wanted hetero-box-photon &&
	    against hetero-box-photon "$VARIANTS/hetero-box.xml" photon
	PM_SPP=$_pm_spp
fi

# Spectra (wavelength:value lists, .spd files, blackbody) reduced to RGB
# as Mitsuba's RGB variants reduce them: noise-free scenes, 1e-4 agreement.
if [ "$selftest" = 0 ] && wanted spectra; then
	"$PY" "$HERE/spectra.py" --pm-render "$PM_RENDER" \
	    --workdir "$OUT/spectra" >"$OUT/spectra.txt" 2>&1
	_rc=$?
	grep -v WARN "$OUT/spectra.txt" | diag
	check "spectra: pm reads spectra as Mitsuba's RGB variants do" \
	    test "$_rc" = 0
fi

# Grid-volume lookups (gridvolume: filters, wrap modes, 1 and 3 channels,
# grids Mitsuba writes), point by point, against Mitsuba's
# (lookup_volume.py).
if [ "$selftest" = 0 ] && wanted grid-lookups; then
	if [ ! -x build/tests/volgen ]; then
		check "grid lookups: build/tests/volgen not built" false
	elif "$PY" "$HERE/lookup_volume.py" build/tests/volgen \
	    "$OUT/grid-lookup" >"$OUT/log" 2>&1; then
		diag <"$OUT/log"
		check "grid lookups: pm reads Mitsuba's .vol grids and looks them up as Mitsuba does" true
	else
		diag <"$OUT/log"
		check "grid lookups: pm's grid lookups differ from Mitsuba's" false
	fi
fi

# Bitmap lookups, point by point, against Mitsuba's (texture_lookup.py).
if [ "$selftest" = 0 ] && wanted texture-lookups; then
	if [ ! -x build/tests/texlookup ]; then
		check "texture lookups: build/tests/texlookup not built" false
	elif "$PY" "$HERE/texture_lookup.py" build/tests/texlookup \
	    "$OUT/texture-lookup" >"$OUT/log" 2>&1; then
		diag <"$OUT/log"
		check "texture lookups: pm's bitmap lookups equal Mitsuba's" true
	else
		diag <"$OUT/log"
		check "texture lookups: pm's bitmap lookups differ from Mitsuba's" false
	fi
fi

# The principled BSDFs: eval and pdf point by point against Mitsuba's
# (bsdf_eval.py), then data/principled.xml by path tracing and by photon
# mapping.
if [ "$selftest" = 0 ] && wanted principled-eval; then
	if [ ! -x build/tests/bsdfeval ]; then
		check "principled eval: build/tests/bsdfeval not built" false
	elif "$PY" "$HERE/bsdf_eval.py" build/tests/bsdfeval \
	    "$OUT/principled-eval" >"$OUT/log" 2>&1; then
		diag <"$OUT/log"
		check "principled eval: pm's principled BSDFs equal Mitsuba's" true
	else
		diag <"$OUT/log"
		check "principled eval: pm's principled BSDFs differ from Mitsuba's" false
	fi
fi
if [ -f data/principled.xml ]; then
	run principled data/principled.xml
	[ "$selftest" = 1 ] || ! wanted principled-photon ||
	    against principled-photon data/principled.xml photon
else
	check "principled: data/principled.xml is missing" false
fi

# Textures: tests/mitsuba/textures.xml with its bitmap written here, in a
# folder of their own (Mitsuba's cache key hashes the scene's folder), by
# path tracing and by photon mapping.
mkdir -p "$OUT/textures"
cp tests/mitsuba/textures.xml "$OUT/textures/textures.xml"
if "$PY" "$HERE/write_png.py" "$OUT/textures/wall.png"; then
	run textures "$OUT/textures/textures.xml"
	[ "$selftest" = 1 ] || ! wanted textures-photon ||
	    against textures-photon "$OUT/textures/textures.xml" photon
else
	check "textures: cannot write the bitmap" false
fi

# Shading frames: tests/mitsuba/frames.xml (anisotropic rough metals and
# glass, normal and bump maps) with its bitmaps written here, in a folder
# of their own as the textures, by path tracing and by photon mapping.
mkdir -p "$OUT/frames"
cp tests/mitsuba/frames.xml "$OUT/frames/frames.xml"
if "$PY" "$HERE/frames_maps.py" "$OUT/frames"; then
	run frames "$OUT/frames/frames.xml"
	[ "$selftest" = 1 ] || ! wanted frames-photon ||
	    against frames-photon "$OUT/frames/frames.xml" photon
else
	check "frames: cannot write the bitmaps" false
fi

# Rough glass and rough plastic, by path tracing and by photon mapping
# (soft caustics through the rough glass come from the caustic map there),
# and every other material by photon mapping.
if [ -f data/rough.xml ]; then
	run rough data/rough.xml
else
	check "rough: data/rough.xml is missing" false
fi
if [ "$selftest" = 0 ]; then
	for scene in rough materials; do
		[ -f data/$scene.xml ] && wanted $scene-photon &&
		    against $scene-photon data/$scene.xml photon
	done
fi

# Shapes and sensors: an open cylinder (and a cylinder light), two meshes
# of a .serialized file written here and two instances of a shapegroup,
# under an orthographic and a thin-lens camera, path traced and from
# photon maps; in a folder of their own, as the textures.
if "$PY" "$HERE/shapes_scene.py" "$OUT/shapes" >"$OUT/log" 2>&1; then
	for cam in ortho thinlens; do
		run shapes-$cam "$OUT/shapes/shapes-$cam.xml"
		[ "$selftest" = 1 ] || ! wanted shapes-$cam-photon ||
		    against shapes-$cam-photon "$OUT/shapes/shapes-$cam.xml" photon
	done
else
	diag <"$OUT/log"
	check "shapes: tests/mitsuba/shapes_scene.py failed" false
fi

# Mitsuba's particle tracer on scenes of data/ (an area light, a sky seen
# directly, point and spot lights), each against Mitsuba's own ptracer;
# in a folder of their own, as the textures.
mkdir -p "$OUT/ptracer"
for scene in cornell-box sky point-lights; do
	if [ -f data/$scene.xml ]; then
		sed 's|<integrator type="path">|<integrator type="ptracer">|' \
		    data/$scene.xml >"$OUT/ptracer/$scene.xml"
		run $scene-ptracer "$OUT/ptracer/$scene.xml"
	else
		check "$scene-ptracer: data/$scene.xml is missing" false
	fi
done

# The moment integrator around the path tracer: the per-pixel variance of
# one sample, in the mean and block by block.
if [ "$selftest" = 0 ] && wanted cornell-moment && [ -f data/cornell-box.xml ]; then
	mkdir -p "$OUT/moment"
	sed 's|<integrator type="path">|<integrator type="moment"><integrator type="path">|; s|</integrator>|</integrator></integrator>|' \
	    data/cornell-box.xml >"$OUT/moment/cornell-box.xml"
	moments cornell-moment "$OUT/moment/cornell-box.xml"
fi

# BSDFs made of others (blendbsdf with a textured weight, mask with a
# checkerboard opacity, twosided with a different BSDF on each side) and
# Mitsuba's named conductors, by path tracing and by photon mapping; and
# pm's table of named conductors, every entry, against what Mitsuba
# reports (conductors.py).
# (not $scene: against sets that)
for nested in composite conductors; do
	run $nested $HERE/$nested.xml
	[ "$selftest" = 1 ] || ! wanted $nested-photon ||
	    against $nested-photon $HERE/$nested.xml photon
done
if [ "$selftest" = 0 ] && wanted conductor-table; then
	"$PY" "$HERE/conductors.py" --check common/conductors.h \
	    >"$OUT/log" 2>&1
	_rc=$?
	diag <"$OUT/log"
	check "conductor table: pm's named conductors are Mitsuba's" \
	    test "$_rc" = 0
fi

if [ -f ../shared/scenes/mitsuba-cbox/cbox-rgb.xml ]; then
	run mitsuba-cbox ../shared/scenes/mitsuba-cbox/cbox-rgb.xml
else
	echo "# ../shared/scenes/mitsuba-cbox absent: Mitsuba's own Cornell box skipped"
fi

echo "# total $(($(now) - t0)) s"
finish mitsuba
