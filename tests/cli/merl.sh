#!/bin/sh
# CLI contract of pm-merl (man/pm-merl.1): usage errors exit 2 with one
# line and write nothing; a written file has the MERL layout of
# /work/shared/MERL.md (its size, dimensions, planes, scales and the -1 of
# bins below the horizon), checked by a reader written here from that
# description; and the round trip: a file this script writes in that exact
# layout, read by pm-render through <bsdf type="merl">, renders what the
# analytic material it tabulates renders, as pm-merl's own file does.
# Run from the repository root: sh tests/cli/merl.sh
. tests/harness.sh
M=$BIN/pm-merl
R=$BIN/pm-render
size=34992012

# merl.py: the layout from the description alone, no pm code.
#   merl.py write OUT R G B      a Lambertian of albedo (R, G, B)
#   merl.py check FILE R G B     FILE is that Lambertian as pm-merl says
#   merl.py dims FILE A B C      a copy of FILE with other dimensions
cat >"$tmp/merl.py" <<'EOF'
import array, math, struct, sys

N = (90, 90, 180)
SCALE = (1 / 1500, 1.15 / 1500, 1.66 / 1500)

def below():
    """Bins whose centre has a direction at or below the horizon, and
    those too close to it (1e-9) to call."""
    out, near = bytearray(N[0] * N[1] * N[2]), bytearray(N[0] * N[1] * N[2])
    i = 0
    for th in range(N[0]):
        t_h = ((th + 0.5) / N[0]) ** 2 * math.pi / 2
        sh, ch = math.sin(t_h), math.cos(t_h)
        for td in range(N[1]):
            t_d = (td + 0.5) / N[1] * math.pi / 2
            sd, cd = math.sin(t_d), math.cos(t_d)
            for pd in range(N[2]):
                dx = sd * math.cos((pd + 0.5) / N[2] * math.pi)
                # wi = d in the frame of h; wo its mirror image about h
                zi = -dx * sh + cd * ch
                zo = dx * sh + cd * ch
                z = min(zi, zo)
                out[i] = z <= 0
                near[i] = abs(z) < 1e-9
                i += 1
    return out, near

def planes(data):
    a = array.array("d")
    a.frombytes(data[12:])
    if sys.byteorder == "big":
        a.byteswap()
    n = N[0] * N[1] * N[2]
    return [a[c * n:(c + 1) * n] for c in range(3)]

cmd = sys.argv[1]
if cmd == "write":
    alb = [float(x) for x in sys.argv[3:6]]
    mask, _ = below()
    out = open(sys.argv[2], "wb")
    out.write(struct.pack("<3i", *N))
    for c in range(3):
        v = alb[c] / math.pi / SCALE[c]
        a = array.array("d", (-1.0 if m else v for m in mask))
        if sys.byteorder == "big":
            a.byteswap()
        out.write(a.tobytes())
    out.close()
elif cmd == "check":
    data = open(sys.argv[2], "rb").read()
    alb = [float(x) for x in sys.argv[3:6]]
    if len(data) != 12 + 8 * 3 * 1458000:
        sys.exit("size %d" % len(data))
    if struct.unpack_from("<3i", data, 0) != N:
        sys.exit("dimensions %s" % (struct.unpack_from("<3i", data, 0),))
    mask, near = below()
    bad = 0
    for c, p in enumerate(planes(data)):
        want = alb[c] / math.pi / SCALE[c]
        for i, v in enumerate(p):
            if near[i]:
                ok = v == -1.0 or abs(v - want) <= 1e-6 * want
            elif mask[i]:
                ok = v == -1.0
            else:
                ok = abs(v - want) <= 1e-6 * want
            if not ok:
                bad += 1
                if bad <= 3:
                    print("# channel %d bin %d: %r, want %r" %
                          (c, i, v, -1.0 if mask[i] else want))
    print("# %d bins below the horizon, %d too close to call, %d wrong" %
          (sum(mask), sum(near), bad))
    sys.exit(bad != 0)
elif cmd == "dims":
    data = bytearray(open(sys.argv[2], "rb").read())
    struct.pack_into("<3i", data, 0, *(int(x) for x in sys.argv[4:7]))
    open(sys.argv[3], "wb").write(data)
EOF

# scene FILE BSDF: a sphere of that BSDF under a constant white sky, seen
# whole; one bounce, so a Lambertian of albedo a shows radiance a.
scene() {
	cat >"$1" <<EOF
<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="2"/></integrator>
<sensor type="perspective"><float name="fov" value="35"/>
<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film></sensor>
$2
<shape type="sphere"><float name="radius" value="1"/><ref id="m"/></shape>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
EOF
}
merl_bsdf() { echo "<bsdf type=\"merl\" id=\"m\"><string name=\"filename\" value=\"$1\"/></bsdf>"; }
# render SCENE OUT: path traced, fixed seed
render() { $R -q -f --seed 3 --spp 64 -o "$2" "$1"; }
# means A B TOL: the channel means of A within TOL (relative) of B's
means() {
	set -- $("$EXRUTIL" relmse "$1" "$2") "$3"
	echo "# means differ by $2 $3 $4 (relative)"
	awk -v r="$2" -v g="$3" -v b="$4" -v t="$5" \
	    'BEGIN { exit !(r * r <= t * t && g * g <= t * t && b * b <= t * t) }'
}

# --- usage ---------------------------------------------------------------
check "--help exits 0" status 0 $M --help
check "...with the usage on stdout" grep -q '^usage: pm-merl ' "$tmp/out"
check "...naming every model" sh -c "grep -q -- --lambert '$tmp/out' && grep -q -- --gold '$tmp/out' && grep -q -- --conductor '$tmp/out' && grep -q -- --plastic '$tmp/out'"
check "--version exits 0" status 0 $M --version
# usage ARGS PATTERN: exit 2, one line matching PATTERN, no file
usage() {
	# shellcheck disable=SC2086
	check "pm-merl $1: exit 2" status 2 $M $1
	check "...in one line: $2" one_line pm-merl "$2"
	check "...writing nothing" test ! -e "$tmp/u.binary"
}
usage "" "no model given"
usage "-o $tmp/u.binary" "no model given"
usage "--alpha 0.1 -o $tmp/u.binary" "no model given"
usage "--gold --lambert 0.5 -o $tmp/u.binary" "more than one model"
usage "--gold" "no output given"
usage "--gold -o $tmp/u.binary extra" "unexpected argument 'extra'"
usage "--lambert 2 -o $tmp/u.binary" "--lambert wants R,G,B in \[0, 1\]"
usage "--lambert -0.1 -o $tmp/u.binary" "--lambert wants R,G,B"
usage "--lambert 0.5,0.5 -o $tmp/u.binary" "--lambert wants R,G,B"
usage "--lambert x -o $tmp/u.binary" "--lambert wants R,G,B"
usage "--gold --alpha 0 -o $tmp/u.binary" "--alpha wants a roughness from 0.001 to 1"
usage "--gold --alpha 1.5 -o $tmp/u.binary" "--alpha wants a roughness"
usage "--gold --alpha 0.0009 -o $tmp/u.binary" "--alpha wants a roughness"
usage "--gold --alpha 0.2x -o $tmp/u.binary" "--alpha"
usage "--gold --ior 1.5 -o $tmp/u.binary" "--ior applies to --plastic only"
usage "--plastic 0.5 --ior 5 -o $tmp/u.binary" "--ior wants an index from 1 to 4"
usage "--plastic 0.5 --ior 0.5 -o $tmp/u.binary" "--ior wants an index"
usage "--conductor Xx -o $tmp/u.binary" "unknown material 'Xx'"
usage "--no-such -o $tmp/u.binary" "unknown option"

# --- runtime errors --------------------------------------------------------
check "an output under a missing directory exits 1" status 1 $M --gold -o "$tmp/no/such/g.binary"
check "...in one line naming it" one_line pm-merl "no/such"
: >"$tmp/old.binary"
check "an existing output without -f exits 1" status 1 $M --gold -o "$tmp/old.binary"
check "...in one line" one_line pm-merl "already exists"
check "...leaving it alone" test ! -s "$tmp/old.binary"

# --- valid output ---------------------------------------------------------
check "--lambert R,G,B writes a file" status 0 $M --lambert 0.5,0.25,0.75 -o "$tmp/lam.binary"
check "...quietly" sh -c "test ! -s '$tmp/err' && test ! -s '$tmp/out'"
check "...of exactly $size bytes" test "$(wc -c <"$tmp/lam.binary")" -eq $size
check "...leaving no temporary file" test "$(ls "$tmp" | grep -c '^lam\.binary.')" -eq 0
check "...laid out as MERL.md says: dimensions, planes, scales, -1 below the horizon" \
    python3 "$tmp/merl.py" check "$tmp/lam.binary" 0.5 0.25 0.75
check "one value means grey" status 0 $M --lambert 0.4 -o "$tmp/grey.binary"
check "...(checked)" python3 "$tmp/merl.py" check "$tmp/grey.binary" 0.4 0.4 0.4
check "-v says what was written" status 0 $M -v --lambert 0.4 -f -o "$tmp/grey.binary"
check "...naming the file" grep -q "grey.binary" "$tmp/err"
check "-f overwrote it with the same bytes" status 0 python3 "$tmp/merl.py" check "$tmp/grey.binary" 0.4 0.4 0.4
check "-o - writes the same bytes to a pipe" sh -c "$M --lambert 0.5,0.25,0.75 -o - | cmp -s - '$tmp/lam.binary'"
check "--gold writes a file" status 0 $M --gold -o "$tmp/gold.binary"
check "...the same as --conductor Au" sh -c "$M --conductor Au -o $tmp/au.binary && cmp -s $tmp/gold.binary $tmp/au.binary"
check "...and not the same as --conductor Cu" sh -c "$M --conductor Cu -o $tmp/cu.binary && ! cmp -s $tmp/gold.binary $tmp/cu.binary"
check "--alpha changes it" sh -c "$M --gold --alpha 0.5 -o $tmp/g5.binary && ! cmp -s $tmp/gold.binary $tmp/g5.binary"
check "--alpha 0.001 and 1 are in range" sh -c "$M --gold --alpha 0.001 -o $tmp/a0.binary && $M --gold --alpha 1 -o $tmp/a1.binary"
check "--plastic with --ior 1 and 4 writes files" sh -c "$M --plastic 0.5 --ior 1 -o $tmp/p1.binary && $M --plastic 0.5 --ior 4 -o $tmp/p4.binary"
check "...of the MERL size" sh -c "test \$(wc -c <$tmp/p1.binary) -eq $size && ! cmp -s $tmp/p1.binary $tmp/p4.binary"

# --- round trip -------------------------------------------------------------
check "a Lambertian file written here in MERL's layout" python3 "$tmp/merl.py" write "$tmp/mine.binary" 0.5 0.5 0.5
check "...is the file pm-merl writes, as MERL.md reads it" python3 "$tmp/merl.py" check "$tmp/mine.binary" 0.5 0.5 0.5
scene "$tmp/mine.xml" "$(merl_bsdf mine.binary)"
scene "$tmp/diffuse.xml" '<bsdf type="diffuse" id="m"><rgb name="reflectance" value="0.5"/></bsdf>'
$M --lambert 0.5 -o "$tmp/pm.binary"
scene "$tmp/pm.xml" "$(merl_bsdf pm.binary)"
if render "$tmp/mine.xml" "$tmp/mine.exr" && render "$tmp/diffuse.xml" "$tmp/diffuse.exr" &&
    render "$tmp/pm.xml" "$tmp/pm.exr"; then
	check "pm-render reads it: the sphere renders as the diffuse one (1%)" means "$tmp/mine.exr" "$tmp/diffuse.exr" 0.01
	check "...and as pm-merl's own file (1e-5)" means "$tmp/mine.exr" "$tmp/pm.exr" 1e-5
else
	check "the three round-trip scenes render" false
fi
python3 "$tmp/merl.py" write "$tmp/dark.binary" 0.4 0.4 0.4
scene "$tmp/dark.xml" "$(merl_bsdf dark.binary)"
render "$tmp/dark.xml" "$tmp/dark.exr"
check "a file of albedo 0.4 does not pass for 0.5 (the comparison can fail)" sh -c \
    'set -- $("$1" relmse "$2" "$3") && echo "# mean red differs by $2" && awk -v r="$2" "BEGIN { exit !(r < -0.05) }"' \
    sh "$EXRUTIL" "$tmp/dark.exr" "$tmp/diffuse.exr"

# --- files pm-render refuses ----------------------------------------------
bad() { # description file pattern
	scene "$tmp/bad.xml" "$(merl_bsdf "$2")"
	check "pm-render: $1 exits 1" status 1 $R -q --spp 1 -o "$tmp/bad.exr" "$tmp/bad.xml"
	check "...in one line naming the file: $3" one_line pm-render "$2.*$3"
	check "...writing no image" test ! -e "$tmp/bad.exr"
}
head -c $((size - 8)) "$tmp/mine.binary" >"$tmp/short.binary"
bad "a file 8 bytes short" short.binary "truncated.*expected $size"
cp "$tmp/mine.binary" "$tmp/long.binary"
printf 'x' >>"$tmp/long.binary"
bad "a byte of trailing data" long.binary "trailing"
python3 "$tmp/merl.py" dims "$tmp/mine.binary" "$tmp/dims.binary" 180 90 90
bad "dimensions 180 x 90 x 90 (the same product)" dims.binary "dimensions 180 x 90 x 90"
head -c 6 "$tmp/mine.binary" >"$tmp/stub.binary"
bad "a 6-byte file" stub.binary "too short"
: >"$tmp/empty.binary"
bad "an empty file" empty.binary "empty"

finish merl
