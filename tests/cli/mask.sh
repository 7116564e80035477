#!/bin/sh
# Masks and blends in whole renders (man/pm-scene.5, BSDFs): a camera
# looking at a masked plane under a white constant environment of
# radiance 1, where the answer is known.  A ray that passes the mask sees
# the environment (1); one that meets its diffuse BSDF of reflectance rho
# sees rho (the plane sees only the environment and never itself), so a
# pixel's mean is (1 - opacity) + opacity rho, by path tracing and by
# photon mapping.  At opacity 0 every ray passes: the image equals, pixel
# for pixel, that of the scene without the plane.  A blend of two diffuse
# BSDFs shows the weighted mean of their reflectances.  Means are checked
# within five standard errors over the pixels (exrutil se).
# Run from the repository root: sh tests/cli/mask.sh
. tests/harness.sh
R=$BIN/pm-render
SHOOT=$BIN/pm-shoot
BAL=$BIN/pm-balance

# scene FILE BSDF: the plane (filling the view) with that BSDF, or none
scene() {
	cat >"$1" <<EOS
<scene version="3.0.0">
	<integrator type="path"/>
	<sensor type="perspective">
		<float name="fov" value="40"/>
		<transform name="to_world">
			<lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/>
		</transform>
		<sampler type="independent">
			<integer name="sample_count" value="32"/>
		</sampler>
		<film type="hdrfilm">
			<integer name="width" value="24"/>
			<integer name="height" value="24"/>
			<rfilter type="box"/>
		</film>
	</sensor>
	<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
	<!-- out of view and behind the plane, where nothing the plane
	     scatters reaches: the scene has an extent without it -->
	<shape type="sphere">
		<point name="center" x="10" y="0" z="-1"/>
		<float name="radius" value="0.5"/>
	</shape>
$2
</scene>
EOS
}
plane() { # BSDF body
	printf '\t<shape type="rectangle">\n\t\t<transform name="to_world"><scale value="3"/></transform>\n%s\n\t</shape>\n' "$1"
}
mask() { # opacity rho
	plane "<bsdf type=\"mask\"><float name=\"opacity\" value=\"$1\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"$2\"/></bsdf></bsdf>"
}

# within FILE WANT: the image's mean is WANT within five standard errors
within() {
	$EXRUTIL se "$1" | awk -v w="$2" '{
		d = $1 - w; if (d < 0) d = -d
		printf "# mean %.6f want %.6f se %.6f\n", $1, w, $2
		exit !(d <= 5 * $2 + 1e-6) }'
}

# photon FILE OUT: a photon-mapped render of FILE
photon() {
	$SHOOT -q -f --seed 3 --photons 20000 -o "$tmp/m.shot" "$1" &&
	    $BAL -q -f -o "$tmp/m.pmap" "$tmp/m.shot" &&
	    $R -q -f --seed 3 -o "$2" "$1" "$tmp/m.pmap"
}

scene "$tmp/empty.xml" ""
scene "$tmp/open.xml" "$(mask 0 0.6)"
scene "$tmp/half.xml" "$(mask 0.5 0.6)"
scene "$tmp/full.xml" "$(mask 1 0.6)"
scene "$tmp/blend.xml" "$(plane '<bsdf type="blendbsdf"><float name="weight" value="0.3"/><bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf><bsdf type="diffuse"><rgb name="reflectance" value="0.9"/></bsdf></bsdf>')"

same_image() { # render-a render-b: the two decode to the same pixels
	$1 "$tmp/a.exr" && $2 "$tmp/b.exr" || return 1
	$EXRUTIL same "$tmp/a.exr" "$tmp/b.exr" >"$tmp/same.txt" 2>&1
	_rc=$?
	sed 's/^/# /' "$tmp/same.txt"
	return $_rc
}
path() { # SCENE SEED OUT
	$R -q -f --seed "$2" -o "$3" "$1"
}
path_empty() { path "$tmp/empty.xml" 5 "$1"; }
path_open() { path "$tmp/open.xml" 5 "$1"; }
photon_open() { photon "$tmp/open.xml" "$1"; }
path_within() { # SCENE SEED WANT
	path "$1" "$2" "$tmp/w.exr" && within "$tmp/w.exr" "$3"
}
photon_within() { # SCENE WANT
	photon "$1" "$tmp/w.exr" && within "$tmp/w.exr" "$2"
}

# A blend of a diffuse BSDF and a smooth conductor, seen straight on by
# an orthographic camera: (1 - w) rho + w F(0), F(0) = ((eta - 1)^2 +
# k^2) / ((eta + 1)^2 + k^2) = 0.04 for eta 1.5, k 0; with w 0.6 and rho
# 0.5, 0.224.  (Mitsuba 3.9.1 shows 0.2725 here: its blendbsdf's samples
# carry their component's density, not the blend's, which its path
# tracer weighs against light samples that use the blend's.)
sed -e 's|<sensor type="perspective">|<sensor type="orthographic">|' \
    -e '/name="fov"/d' "$tmp/empty.xml" >"$tmp/ortho.xml"
sed "s|<!-- out of view|$(plane '<bsdf type="blendbsdf"><float name="weight" value="0.6"/><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf><bsdf type="conductor"><rgb name="eta" value="1.5"/><rgb name="k" value="0"/></bsdf></bsdf>' | tr '\n' ' ')<!-- out of view|" \
    "$tmp/ortho.xml" >"$tmp/mirror.xml"

check "path: a mask of opacity 0 renders the scene without it, pixel for pixel" \
    same_image path_empty path_open
check "path: opacity 0.5 over reflectance 0.6 shows 0.8" \
    path_within "$tmp/half.xml" 6 0.8
check "path: opacity 1 over reflectance 0.6 shows 0.6" \
    path_within "$tmp/full.xml" 7 0.6
check "path: a blend of 0.2 and 0.9 at weight 0.3 shows 0.41" \
    path_within "$tmp/blend.xml" 8 0.41
check "path: a blend of paint and a mirror shows (1 - w) rho + w F" \
    path_within "$tmp/mirror.xml" 9 0.224
check "photon: a mask of opacity 0 renders the scene without it, pixel for pixel" \
    same_image photon_open path_empty
check "photon: opacity 0.5 over reflectance 0.6 shows 0.8" \
    photon_within "$tmp/half.xml" 0.8
check "photon: a blend of 0.2 and 0.9 at weight 0.3 shows 0.41" \
    photon_within "$tmp/blend.xml" 0.41
check "photon: a blend of paint and a mirror shows (1 - w) rho + w F" \
    photon_within "$tmp/mirror.xml" 0.224
finish mask
