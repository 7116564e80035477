#!/bin/sh
# Images say where they came from: pm-render's OpenEXR output carries its
# version, command line, scene, scene hash and map as string attributes
# (man/pm-render.1), and pm-downsample carries them through, adding its own
# (man/pm-downsample.1); the pixels are those of the render, untouched.
# Attributes are read back with tests/cli/exrutil.c's "attrs".
# Run from the repository root: sh tests/cli/provenance.sh
. tests/harness.sh
R=$BIN/pm-render
D=$BIN/pm-downsample
S=$BIN/pm-shoot
B=$BIN/pm-balance
I=$BIN/pm-inspect
scene=data/cornell-box.xml

# attr FILE NAME: the value of one string attribute ("" when absent)
attr() { "$EXRUTIL" attrs "$1" | awk -F'\t' -v k="$2" '$1 == k { sub(/^[^\t]*\t/, ""); print }'; }
# names FILE: the attribute names, one line, in file order
names() { "$EXRUTIL" attrs "$1" | cut -f1 | tr '\n' ' ' | sed 's/ $//'; }
# words FILE NAME: the words of a recorded command line as the shell reads
# them back, one per line
words() { eval "set -- $(attr "$1" "$2")" && printf '%s\n' "$@"; }

version=$(sed -n 's/^#define PM_VERSION "\(.*\)"$/\1/p' tools/cli.h)
check "tools/cli.h defines PM_VERSION" test -n "$version"

# --- pm-render, path traced --------------------------------------------
mkdir "$tmp/a dir"
out="$tmp/a dir/it's.exr"
check "pm-render writes an image" status 0 $R -q --spp 1 --size 8x8 -D max_depth=3 -o "$out" $scene
check "...carrying pm-render's attributes in order, no map" same "$(names "$out")" \
    "pm-render.version pm-render.command pm-render.scene pm-render.scene_hash"
check "...the project's version" same "$(attr "$out" pm-render.version)" "$version"
check "...the scene as named" same "$(attr "$out" pm-render.scene)" "$scene"
printf '%s\n' $R -q --spp 1 --size 8x8 -D max_depth=3 -o "$out" $scene >"$tmp/want"
words "$out" pm-render.command >"$tmp/got"
check "...the command line, read back by the shell word for word" cmp -s "$tmp/got" "$tmp/want"
cp "$out" "$tmp/first.exr"
check "...which, run again (-f), renders the same pixels" sh -c 'eval "$1 -f" && "$2" same "$3" "$4"' \
    sh "$(attr "$out" pm-render.command)" "$EXRUTIL" "$tmp/first.exr" "$out" >/dev/null

# --- pm-render with a map ------------------------------------------------
$S -q --seed 3 --photons 3000 -o "$tmp/shot.pmap" $scene && $B -q -o "$tmp/m.pmap" "$tmp/shot.pmap"
check "a photon render writes an image" status 0 $R -q --spp 1 --size 8x8 -o "$tmp/pm.exr" $scene "$tmp/m.pmap"
check "...naming the map as well" same "$(attr "$tmp/pm.exr" pm-render.map)" "$tmp/m.pmap"
check "...and the scene hash the map records" same "$(attr "$tmp/pm.exr" pm-render.scene_hash)" \
    "$($I "$tmp/m.pmap" | awk -F'\t' '$1 == "scene_hash" { print $2 }')"
check "...which is the path-traced image's too" same "$(attr "$tmp/pm.exr" pm-render.scene_hash)" \
    "$(attr "$out" pm-render.scene_hash)"
check "another scene has another hash" status 0 $R -q --spp 1 --size 8x8 -o "$tmp/caustics.exr" data/caustics.xml
check "...recorded" sh -c "test -n '$(attr "$tmp/caustics.exr" pm-render.scene_hash)' &&
    test '$(attr "$tmp/caustics.exr" pm-render.scene_hash)' != '$(attr "$out" pm-render.scene_hash)'"
check "--half output carries them too" status 0 $R -q --half --spp 1 --size 8x8 -o "$tmp/half.exr" $scene "$tmp/m.pmap"
check "...all five" same "$(names "$tmp/half.exr")" \
    "pm-render.version pm-render.command pm-render.scene pm-render.scene_hash pm-render.map"
printf '0,1,3.8 0,1,0 0,1,0\n0.5,1,3.8 0,1,0 0,1,0\n' >"$tmp/cams.txt"
check "every camera's image of --cameras carries them" sh -c "$R -q --spp 1 --size 8x8 --cameras $tmp/cams.txt -o $tmp/cam.exr $scene &&
    '$EXRUTIL' attrs $tmp/cam-0001.exr | grep -q '^pm-render.command	.*--cameras' &&
    '$EXRUTIL' attrs $tmp/cam-0002.exr | grep -q '^pm-render.command	.*--cameras'"
check "the preview image carries none" sh -c "$R -q --spp 1 --size 8x8 --preview $tmp/pv.exr -o $tmp/pvout.exr $scene &&
    test -z \"\$('$EXRUTIL' attrs $tmp/pv.exr)\" && test -n \"\$('$EXRUTIL' attrs $tmp/pvout.exr)\""

# --- pm-downsample ---------------------------------------------------------
check "pm-downsample averages two renders" status 0 $D -o "$tmp/avg.exr" "$tmp/pm.exr" "$tmp/half.exr"
check "...keeping the first input's attributes, then adding its own" same "$(names "$tmp/avg.exr")" \
    "pm-render.version pm-render.command pm-render.scene pm-render.scene_hash pm-render.map pm-downsample.version pm-downsample.command"
"$EXRUTIL" attrs "$tmp/pm.exr" >"$tmp/in.attrs"
"$EXRUTIL" attrs "$tmp/avg.exr" | head -n 5 >"$tmp/carried.attrs"
check "...pm-render's values unchanged" cmp -s "$tmp/in.attrs" "$tmp/carried.attrs"
check "...its own version" same "$(attr "$tmp/avg.exr" pm-downsample.version)" "$version"
printf '%s\n' $D -o "$tmp/avg.exr" "$tmp/pm.exr" "$tmp/half.exr" >"$tmp/want"
words "$tmp/avg.exr" pm-downsample.command >"$tmp/got"
check "...and its command line, naming every input" cmp -s "$tmp/got" "$tmp/want"
check "downsampling by 2" status 0 $D --factor 2 -o "$tmp/small.exr" "$tmp/avg.exr"
check "...replaces pm-downsample's own attributes, keeping pm-render's" same "$(names "$tmp/small.exr")" \
    "pm-render.version pm-render.command pm-render.scene pm-render.scene_hash pm-render.map pm-downsample.version pm-downsample.command"
check "...with the new command line" sh -c "'$EXRUTIL' attrs $tmp/small.exr | grep -q '^pm-downsample.command	.* --factor 2 .*/avg.exr\$'"
check "a copy (factor 1) keeps every pixel bit for bit" status 0 $D -o "$tmp/copy.exr" "$out"
check "...(compared)" status 0 "$EXRUTIL" same "$tmp/copy.exr" "$out"
"$EXRUTIL" make "$tmp/foreign.exr" 4 4 1 2 3 owner=someone comments="made elsewhere"
check "another program's string attributes are carried too" status 0 $D -o "$tmp/f.exr" "$tmp/foreign.exr"
check "...in their order, before pm-downsample's" same "$(names "$tmp/f.exr")" \
    "owner comments pm-downsample.version pm-downsample.command"
check "...unchanged" same "$(attr "$tmp/f.exr" comments)" "made elsewhere"
check "PNG output succeeds (it carries none)" status 0 $D -o "$tmp/f.png" "$tmp/foreign.exr"

finish provenance
