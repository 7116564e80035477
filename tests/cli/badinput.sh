#!/bin/sh
# Bad input through the tools: every case must exit 1 (2 for a usage
# error) with one line on stderr that names the file or option and says
# what was wrong, never a crash, and leave no output behind.  Covers scene
# XML, meshes, photon maps, images, senseless sizes and counts, requests
# larger than the machine, and outputs that cannot be written.
# Run from the repository root: sh tests/cli/badinput.sh
. tests/harness.sh
R=$BIN/pm-render
S=$BIN/pm-shoot
B=$BIN/pm-balance
I=$BIN/pm-inspect
D=$BIN/pm-downsample

# refused STATUS PATTERN command...: the command exits STATUS with exactly
# one line on stderr matching PATTERN (grep -E, case-insensitive), and
# writes no output file ($tmp/o.*).
refused() {
	want=$1
	pat=$2
	shift 2
	rm -f "$tmp"/o.*
	"$@" >"$tmp/out" 2>"$tmp/err"
	got=$?
	if [ "$got" -ne "$want" ]; then
		echo "# exit $got, wanted $want: $*"; sed 's/^/# /' "$tmp/err"; return 1
	fi
	if [ "$(wc -l <"$tmp/err")" -ne 1 ]; then
		echo "# not one line:"; sed 's/^/# /' "$tmp/err"; return 1
	fi
	if ! grep -qiE -- "$pat" "$tmp/err"; then
		echo "# message lacks /$pat/:"; sed 's/^/# /' "$tmp/err"; return 1
	fi
	if ls "$tmp"/o.* >/dev/null 2>&1; then
		echo "# left an output behind"; return 1
	fi
}
# scene NAME BODY: a scene file around BODY.
scene() {
	printf '<scene version="3.0.0">\n%s\n</scene>\n' "$2" >"$tmp/$1"
}
# Both scene readers: the renderer and the shooter.
xml_refused() { # description pattern file
	check "pm-render: $1" refused 1 "$2" $R -q --spp 1 --size 8x8 -o "$tmp/o.exr" "$tmp/$3"
	check "pm-shoot: $1" refused 1 "$2" $S -q --photons 100 -o "$tmp/o.pmap" "$tmp/$3"
}

light='<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>'

# --- scene XML -------------------------------------------------------
printf '' >"$tmp/empty.xml"
xml_refused "an empty file" "empty.xml" empty.xml
printf '<scene version="3.0.0">\n<shape type="sphere">\n</scene>\n' >"$tmp/malformed.xml"
xml_refused "malformed XML" "malformed.xml:3" malformed.xml
scene unknown-elem.xml '<teapot/>'
xml_refused "an unknown element" "unknown-elem.xml:2.*teapot" unknown-elem.xml
scene unknown-plugin.xml '<bsdf type="velvet" id="v"/>'
xml_refused "an unknown plugin" "unknown-plugin.xml:2.*velvet" unknown-plugin.xml
scene unknown-param.xml "<shape type=\"sphere\"><float name=\"radios\" value=\"1\"/></shape>$light"
xml_refused "an unknown parameter" "unknown-param.xml:2.*radios" unknown-param.xml
scene mistyped.xml "<shape type=\"sphere\"><rgb name=\"radius\" value=\"1\"/></shape>$light"
xml_refused "a mistyped parameter" "mistyped.xml:2.*radius" mistyped.xml
scene mistyped2.xml "<integrator type=\"path\"><float name=\"max_depth\" value=\"2.5\"/></integrator>$light"
xml_refused "a float where an integer belongs" "mistyped2.xml:2.*max_depth" mistyped2.xml
scene missing.xml "<shape type=\"obj\"/>$light"
xml_refused "a missing required parameter" "missing.xml:2.*filename" missing.xml
scene badnum.xml "<shape type=\"sphere\"><float name=\"radius\" value=\"1.5x\"/></shape>$light"
xml_refused "a bad number" "badnum.xml:2.*1\\.5x" badnum.xml
scene hugenum.xml "<shape type=\"sphere\"><float name=\"radius\" value=\"1e999\"/></shape>$light"
xml_refused "a number out of range" "hugenum.xml:2" hugenum.xml
scene nanrgb.xml "<shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"nan\"/></emitter></shape>"
xml_refused "a NaN radiance" "nanrgb.xml:2" nanrgb.xml
scene undef.xml "<shape type=\"sphere\"><float name=\"radius\" value=\"\$size\"/></shape>$light"
xml_refused "an undefined \$name" "undef.xml:2.*size" undef.xml
scene badref.xml "<shape type=\"sphere\"><ref id=\"nowhere\"/></shape>$light"
xml_refused "an unknown ref" "badref.xml:2.*nowhere" badref.xml
printf '<scene version="3.0.0">\n<include filename="cycle-b.xml"/>\n</scene>\n' >"$tmp/cycle-a.xml"
printf '<scene version="3.0.0">\n<include filename="cycle-a.xml"/>\n</scene>\n' >"$tmp/cycle-b.xml"
xml_refused "an include cycle" "cycle.*(cycle|includ)" cycle-a.xml
scene neg.xml "<shape type=\"sphere\"><float name=\"radius\" value=\"-1\"/></shape>$light"
xml_refused "a negative radius" "neg.xml:2.*radius" neg.xml

# --- participating media: photon mode shoots a volume map (pmap 2.1) ---
scene bad-medium.xml "<shape type=\"sphere\"><bsdf type=\"null\"/>
<medium type=\"nebula\" name=\"interior\"/></shape>$light"
xml_refused "an unknown medium type" "bad-medium.xml:3.*nebula" bad-medium.xml
check "pm-shoot: a scene with a medium, exit 0" status 0 \
    $S -q --photons 2000 -o "$tmp/fog.pmap" data/fog-box.xml
check "pm-balance: its volume map, exit 0" status 0 \
    bin/pm-balance -q -o "$tmp/fogb.pmap" "$tmp/fog.pmap"
check "pm-inspect: version 2.1, a balanced volume map of 2000 paths" \
    status 0 bin/pm-inspect --map volume "$tmp/fogb.pmap"
check "...whose report says so" sh -c "grep -q '^version	2.1$' $tmp/out &&
    grep -q '^volume.emitted	2000$' $tmp/out &&
    grep -q '^volume.balanced	true$' $tmp/out &&
    grep -q '^effects	.*media' $tmp/out"
check "pm-render: a scene with a medium, photon mode, exit 0" status 0 \
    $R -q --spp 1 --size 8x8 -o "$tmp/fogp.exr" data/fog-box.xml "$tmp/fogb.pmap"
check "pm-render: ...and path mode, exit 0" status 0 \
    $R -q --spp 1 --size 8x8 -o "$tmp/fog.exr" data/fog-box.xml
check "pm-render: --volume-estimate other than point or beam refused" \
    status 2 $R --volume-estimate cone -o "$tmp/x.exr" data/fog-box.xml
if [ -f data/smoke.vol ]; then
	check "pm-shoot: a heterogeneous medium, exit 0" status 0 \
	    $S -q --photons 2000 -o "$tmp/smoke.pmap" data/smoke.xml
	check "pm-balance: its volume map, exit 0" status 0 \
	    bin/pm-balance -q -o "$tmp/smokeb.pmap" "$tmp/smoke.pmap"
	check "pm-render: ...in photon mode, exit 0" status 0 \
	    $R -q --spp 1 --size 8x8 -o "$tmp/smokep.exr" data/smoke.xml \
	    "$tmp/smokeb.pmap"
	check "pm-render: ...and path mode, exit 0" status 0 \
	    $R -q --spp 1 --size 8x8 -o "$tmp/smoke.exr" data/smoke.xml
fi

# --- meshes ------------------------------------------------------------
mesh_refused() { # description pattern mesh-file-name type
	scene "m-$3.xml" "<shape type=\"$4\"><string name=\"filename\" value=\"$3\"/></shape>$light"
	xml_refused "$1" "$2" "m-$3.xml"
}
mesh_refused "a missing OBJ" "nope\\.obj" nope.obj obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n' >"$tmp/range.obj"
mesh_refused "OBJ indices out of range" "range\\.obj:4" range.obj obj
printf 'v 0 0 0\nv 1 0 zero\nv 0 1 0\nf 1 2 3\n' >"$tmp/malformed.obj"
mesh_refused "a malformed OBJ number" "malformed\\.obj:2" malformed.obj obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n' >"$tmp/short.obj"
mesh_refused "an OBJ face of two vertices" "short\\.obj:4" short.obj obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3' >"$tmp/ok.obj"
head -c 20 "$tmp/ok.obj" >"$tmp/trunc.obj"
mesh_refused "a truncated OBJ (a face cut short)" "trunc\\.obj" trunc.obj obj
ply_head='ply\nformat binary_little_endian 1.0\nelement vertex %s\nproperty float x\nproperty float y\nproperty float z\nelement face %s\nproperty list uchar int vertex_indices\nend_header\n'
# shellcheck disable=SC2059
printf "$ply_head" 3 1 >"$tmp/trunc.ply"
head -c 30 /dev/zero >>"$tmp/trunc.ply"
mesh_refused "a truncated binary PLY" "trunc\\.ply" trunc.ply ply
# shellcheck disable=SC2059
printf "$ply_head" 4000000000 4000000000 >"$tmp/absurd.ply"
head -c 64 /dev/zero >>"$tmp/absurd.ply"
mesh_refused "absurd PLY element counts" "absurd\\.ply" absurd.ply ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n' >"$tmp/range.ply"
mesh_refused "PLY indices out of range" "range\\.ply" range.ply ply
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n' >"$tmp/noxyz.ply"
mesh_refused "a PLY without y and z" "noxyz\\.ply" noxyz.ply ply
printf 'PLY?\n' >"$tmp/magic.ply"
mesh_refused "a PLY with a wrong magic" "magic\\.ply" magic.ply ply
# Mitsuba's serialized meshes: a stream cut short, and no magic at all.
cp tests/fuzz/corpus/serialized/truncated.serialized "$tmp/trunc.serialized"
mesh_refused "a truncated serialized mesh" \
    "trunc\\.serialized: the compressed data ends inside" trunc.serialized serialized
printf 'PK\003\004 zip' >"$tmp/magic.serialized"
mesh_refused "a serialized mesh with a wrong magic" \
    "magic\\.serialized: not a Mitsuba serialized mesh" magic.serialized serialized

# Non-finite vertices and zero-area triangles are dropped, with one warning
# that counts them; the rest renders.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv inf 1 1\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 5 2 3\nf 1 2 6\n' >"$tmp/nonfinite.obj"
scene nonfinite.xml "<shape type=\"obj\"><string name=\"filename\" value=\"nonfinite.obj\"/></shape>$light"
check "pm-shoot: non-finite and degenerate triangles are dropped, exit 0" status 0 $S --photons 100 -o "$tmp/nf.pmap" "$tmp/nonfinite.xml"
check "...with one warning counting them (3)" sh -c "grep -c 'warning' $tmp/err | grep -qx 1 && grep -q '3 degenerate' $tmp/err"
check "pm-render: the same scene renders, exit 0" status 0 $R --spp 1 --size 8x8 --eye 0,0,3 --target 0,0,0 -o "$tmp/nf.exr" "$tmp/nonfinite.xml"
check "...with one warning counting the dropped triangles (3)" sh -c "grep -c 'warning' $tmp/err | grep -qx 1 && grep -q '3 degenerate' $tmp/err"

# --- photon maps -------------------------------------------------------
$S -q --photons 2000 -o "$tmp/good.pmap" data/cornell-box.xml
$B -q -o "$tmp/bal.pmap" "$tmp/good.pmap"
patch_bytes() { # in out offset hexbytes: a copy with bytes replaced
	python3 -c "
import sys
b = bytearray(open(sys.argv[1], 'rb').read())
off = int(sys.argv[3]); new = bytes.fromhex(sys.argv[4])
b[off:off + len(new)] = new
open(sys.argv[2], 'wb').write(b)" "$@"
}
map_refused() { # description pattern file
	check "pm-inspect: $1" refused 1 "$2" $I "$tmp/$3"
	check "pm-balance: $1" refused 1 "$2" $B -o "$tmp/o.pmap" "$tmp/$3"
	check "pm-render: $1" refused 1 "$2" $R -q --spp 1 --size 8x8 -o "$tmp/o.exr" data/cornell-box.xml "$tmp/$3"
}
patch_bytes "$tmp/bal.pmap" "$tmp/magic.pmap" 0 "89504e470d0a1a0a"
map_refused "a PNG's magic" "magic.pmap.*(magic|not a photon map)" magic.pmap
patch_bytes "$tmp/bal.pmap" "$tmp/version.pmap" 8 "0300"
map_refused "an unknown major version" "version.pmap.*unknown version 3\.0" version.pmap
# A real version 1 file (pmap(5)'s example as version 1.0 wrote it).
cp tests/golden/pmap-1.0.pmap "$tmp/v1.pmap"
map_refused "a version 1 map" "v1.pmap: a version 1\.0 photon map.*shoot it again" v1.pmap
head -c 100 "$tmp/bal.pmap" >"$tmp/header.pmap"
map_refused "a file cut inside the header" "header.pmap" header.pmap
head -c $(($(wc -c <"$tmp/bal.pmap") - 7)) "$tmp/bal.pmap" >"$tmp/cut.pmap"
map_refused "a file cut inside the photons" "cut.pmap.*(truncat|end|short)" cut.pmap
size=$(wc -c <"$tmp/bal.pmap")
patch_bytes "$tmp/bal.pmap" "$tmp/flip.pmap" $((size - 3)) "ff"
map_refused "a photon byte flipped (checksum)" "flip.pmap.*(crc|checksum)" flip.pmap
# the map table's count field (entry at 64, count at +16), header crc fixed
python3 - "$tmp/bal.pmap" "$tmp/count.pmap" <<'EOF'
import struct, sys, zlib
b = bytearray(open(sys.argv[1], "rb").read())
hs = struct.unpack_from("<I", b, 12)[0]
struct.pack_into("<Q", b, 64 + 16, 1 << 40)
struct.pack_into("<I", b, hs - 4, zlib.crc32(bytes(b[:hs - 4])))
open(sys.argv[2], "wb").write(b)
EOF
map_refused "a photon count past the end of the file" "count.pmap" count.pmap
python3 - "$tmp/bal.pmap" "$tmp/offset.pmap" <<'EOF'
import struct, sys, zlib
b = bytearray(open(sys.argv[1], "rb").read())
hs = struct.unpack_from("<I", b, 12)[0]
struct.pack_into("<Q", b, 64 + 40, (1 << 63) + 5)
struct.pack_into("<I", b, hs - 4, zlib.crc32(bytes(b[:hs - 4])))
open(sys.argv[2], "wb").write(b)
EOF
map_refused "an offset past the end of the file" "offset.pmap" offset.pmap
printf '' >"$tmp/empty.pmap"
map_refused "an empty file" "empty.pmap" empty.pmap
$S -q --photons 2000 -o "$tmp/other.pmap" data/point-lights.xml
$B -q -o "$tmp/other-bal.pmap" "$tmp/other.pmap"
check "pm-render: a map shot in another scene" refused 1 "other-bal.pmap.*scene" \
    $R -q --spp 1 --size 8x8 -o "$tmp/o.exr" data/cornell-box.xml "$tmp/other-bal.pmap"
check "pm-render: an unbalanced map" refused 1 "good.pmap.*balance" \
    $R -q --spp 1 --size 8x8 -o "$tmp/o.exr" data/cornell-box.xml "$tmp/good.pmap"
check "pm-balance: shards of two scenes" refused 1 "scene" \
    $B -o "$tmp/o.pmap" "$tmp/good.pmap" "$tmp/other.pmap"

# --- images ------------------------------------------------------------
$EXRUTIL make "$tmp/img.exr" 6 4 0.5 0.5 0.5
head -c 200 "$tmp/img.exr" >"$tmp/cut.exr"
check "pm-downsample: a truncated EXR" refused 1 "cut.exr" $D -o "$tmp/o.exr" "$tmp/cut.exr"
printf 'v/1\001garbage that is not an image' >"$tmp/junk.exr"
check "pm-downsample: a file that is not an EXR" refused 1 "junk.exr" $D -o "$tmp/o.exr" "$tmp/junk.exr"
patch_bytes "$tmp/img.exr" "$tmp/bits.exr" 300 "ffffffffffffffff"
check "pm-downsample: a damaged EXR" refused 1 "bits.exr" $D -o "$tmp/o.exr" "$tmp/bits.exr"
check "pm-downsample: a size the factor does not divide" refused 1 "6x4.*(divi|factor)" $D --factor 4 -o "$tmp/o.exr" "$tmp/img.exr"
$EXRUTIL make "$tmp/img2.exr" 8 4 0.5 0.5 0.5
check "pm-downsample: passes of different sizes" refused 1 "img2.exr" $D -o "$tmp/o.exr" "$tmp/img.exr" "$tmp/img2.exr"
check "pm-downsample: --factor 0 is a usage error" status 2 $D --factor 0 -o "$tmp/o.exr" "$tmp/img.exr"

# --- senseless sizes and counts ---------------------------------------
for a in "--spp 0" "--spp -4" "--size 0x16" "--size 16x0" "--size -8x8" "--size 8x" "-t 0"; do
	# shellcheck disable=SC2086
	check "pm-render $a is a usage error" status 2 $R $a -o "$tmp/o.exr" data/cornell-box.xml
done
for a in "--photons -1" "--photons 1e9" "--caustic-photons x" "-t -2" "--max-depth -5"; do
	# shellcheck disable=SC2086
	check "pm-shoot $a is a usage error" status 2 $S $a -o "$tmp/o.pmap" data/cornell-box.xml
done
check "pm-render --size 65536x65536 is refused (exit 1)" refused 1 "65536x65536" \
    $R -q --spp 1 --size 65536x65536 -o "$tmp/o.exr" data/cornell-box.xml
# A map written to a file as it is shot needs disk, not memory; one kept
# whole (to standard output, compressed, or with a volume map) memory.
check "pm-shoot --photons 2^40 is refused before shooting, saying how much disk it needs" \
    refused 1 "GiB of disk, and its file system has .* GiB free" \
    $S -q --photons 1099511627776 -o "$tmp/o.pmap" data/cornell-box.xml
check "...and with --compress, how much memory" \
    refused 1 "GiB of memory, and this machine has" \
    $S -q --compress --photons 1099511627776 -o "$tmp/o.pmap" data/cornell-box.xml

# --- outputs -----------------------------------------------------------
: >"$tmp/file"
check "pm-render: output under a missing directory" refused 1 "no/such" \
    $R -q --spp 1 --size 8x8 -o "$tmp/no/such/o.exr" data/cornell-box.xml
check "pm-render: output under a file" refused 1 "file/o.exr" \
    $R -q --spp 1 --size 8x8 -o "$tmp/file/o.exr" data/cornell-box.xml
check "pm-shoot: output under a missing directory" refused 1 "no/such" \
    $S -q --photons 10 -o "$tmp/no/such/o.pmap" data/cornell-box.xml
check "pm-shoot: output under a file" refused 1 "file/o.pmap" \
    $S -q --photons 10 -o "$tmp/file/o.pmap" data/cornell-box.xml
check "pm-balance: output under a file" refused 1 "file/o.pmap" \
    $B -q -o "$tmp/file/o.pmap" "$tmp/good.pmap"
check "pm-downsample: output under a file" refused 1 "file/o.exr" \
    $D -q -o "$tmp/file/o.exr" "$tmp/img.exr"
check "pm-downsample: PNG output under a missing directory" refused 1 "no/such" \
    $D -q -o "$tmp/no/such/o.png" "$tmp/img.exr"
check "no temporary file is left anywhere" test "$(find "$tmp" -name '*.tmp*' -o -name 'o.*' | wc -l)" -eq 0

finish "bad input"
