#!/bin/sh
# CLI contract of pm-balance and pm-inspect on maps made by pm-shoot: exit
# codes and messages, shards merging into exactly the map of one run,
# refusals, pipes, the report, the checks and the point-cloud dumps.
# Run from the repository root: sh tests/cli/photon.sh
. tests/harness.sh
SHOOT=$BIN/pm-shoot
# Maps of photons only, unless a check asks for irradiance records: the
# checks of merging and dumping count photons.
BAL="$BIN/pm-balance --irradiance-stride 0"
BALI=$BIN/pm-balance
INS=$BIN/pm-inspect
scene=data/cornell-box.xml
scene2=data/point-lights.xml
caustic_scene=data/caustics.xml

key() { # file key: the first value of one key of pm-inspect's report
	$INS "$1" | awk -F'\t' -v k="$2" '$1 == k { print $2 }'
}
content() { # file: the report less what names the file or its history
	$INS "$1" | grep -v -e '^file' -e '^bytes_per_photon	' -e '^info	'
}
same_content() { # a b: both hold the same photons in the same order
	content "$1" >"$tmp/c1" && content "$2" >"$tmp/c2" && cmp -s "$tmp/c1" "$tmp/c2" &&
	    grep -q '^global.records_crc32' "$tmp/c1"
}
# Swaps the first and last photons of the first map of an uncompressed
# map file (or, with "reverse", reverses them all) and fixes both
# checksums, as pmap(5) lays them out: a file that reads cleanly but whose
# kd-tree order is broken.
break_order() {
	python3 - "$1" "${2:-swap}" <<'EOF'
import struct, sys, zlib
b = bytearray(open(sys.argv[1], "rb").read())
hs = struct.unpack_from("<I", b, 12)[0]
e = 64
count, emitted, first, off, stored = struct.unpack_from("<5Q", b, e + 16)
assert struct.unpack_from("<I", b, e + 8)[0] == 0 and count >= 2
rec = 24
last = off + rec * (count - 1)
if sys.argv[2] == "reverse":
    r = [b[off + rec * i:off + rec * i + rec] for i in range(count)]
    b[off:off + rec * count] = b"".join(reversed(r))
else:
    b[off:off + rec], b[last:last + rec] = b[last:last + rec], b[off:off + rec]
struct.pack_into("<I", b, e + 12, zlib.crc32(b[off:off + stored]))
struct.pack_into("<I", b, hs - 4, zlib.crc32(b[:hs - 4]))
open(sys.argv[1], "wb").write(b)
EOF
}

# Adds to an uncompressed map file an irradiance map (kind 3), laid out as
# pmap(5) says, whose records are the global map's (so in kd-tree order)
# with E = the photon's power, no direction, depth 0, and the given
# lookup radius: what pm-balance will write, before it can.
add_irradiance() { # in out radius
	python3 - "$@" <<'EOF'
import struct, sys, zlib
b = open(sys.argv[1], "rb").read()
n, esize, isize = struct.unpack_from("<3I", b, 44)
assert esize == 96
ents = [bytearray(b[64 + 96 * i:64 + 96 * (i + 1)]) for i in range(n)]
info = b[64 + 96 * n:64 + 96 * n + isize]
pays = []
for e in ents:
    kind, flags, comp = struct.unpack_from("<3I", e, 0)
    off, stored = struct.unpack_from("<2Q", e, 40)
    assert comp == 0
    pays.append(b[off:off + stored])
    if kind == 1:
        g, irr = e, bytearray(pays[-1])
for i in range(0, len(irr), 24):
    irr[i + 16:i + 18] = b"\0\0"
    irr[i + 20] &= 3
    irr[i + 21] = 0
e = bytearray(g)
struct.pack_into("<4I", e, 0, 3, 1, 0, zlib.crc32(irr))
struct.pack_into("<2Q", e, 24, 0, 0)
struct.pack_into("<f", e, 80, float(sys.argv[3]))
ents.append(e)
pays.append(bytes(irr))
hs = 64 + 96 * len(ents) + isize + 4
off = (hs + 63) // 64 * 64
for e, p in zip(ents, pays):
    struct.pack_into("<Q", e, 40, off)
    off = (off + len(p) + 63) // 64 * 64
h = bytearray(b[:64])
struct.pack_into("<I", h, 12, hs)
struct.pack_into("<I", h, 44, len(ents))
h += b"".join(ents) + info
h += struct.pack("<I", zlib.crc32(h))
out = bytearray(h)
for e, p in zip(ents, pays):
    out += bytes(struct.unpack_from("<Q", e, 40)[0] - len(out)) + p
open(sys.argv[2], "wb").write(out)
EOF
}

# --- Usage ---
check "pm-balance --help exits 0" status 0 $BAL --help
check "...and prints the synopsis on stdout" grep -q '^usage: pm-balance' "$tmp/out"
check "pm-balance --version exits 0" status 0 $BAL --version
check "pm-inspect --help exits 0" status 0 $INS --help
check "...and prints the synopsis on stdout" grep -q '^usage: pm-inspect' "$tmp/out"
check "pm-inspect --version exits 0" status 0 $INS --version
check "pm-balance: unknown option exits 2" status 2 $BAL --no-such-option -o "$tmp/x.pmap" "$tmp/a.pmap"
check "pm-balance: missing -o exits 2" status 2 $BAL "$tmp/a.pmap"
check "pm-balance: no input exits 2" status 2 $BAL -o "$tmp/x.pmap"
check "pm-balance: -t 0 exits 2" status 2 $BAL -t 0 -o "$tmp/x.pmap" "$tmp/a.pmap"
check "pm-balance: standard input twice exits 2" status 2 $BAL -o "$tmp/x.pmap" - -
check "...in one line" one_line
check "pm-inspect: no map exits 2" status 2 $INS
check "pm-inspect: two maps exit 2" status 2 $INS "$tmp/a.pmap" "$tmp/b.pmap"
check "pm-inspect: unknown dump format exits 2" status 2 $INS --dump obj "$tmp/a.pmap"
check "pm-inspect: unknown map kind exits 2" status 2 $INS --map smoke "$tmp/a.pmap"
check "pm-inspect: --map volume of a file without one exits 1" status 1 $INS --map volume "$tmp/a.pmap"
check "pm-inspect: -k without --knn-check exits 2" status 2 $INS -k 5 "$tmp/a.pmap"
check "pm-inspect: --knn-check 0 exits 2" status 2 $INS --knn-check 0 "$tmp/a.pmap"
check "pm-inspect: --knn-check with junk exits 2" status 2 $INS --knn-check 10x "$tmp/a.pmap"
check "pm-inspect: --dump with --json exits 2" status 2 $INS --dump xyz --json "$tmp/a.pmap"

# --- Missing and corrupt files ---
check "pm-balance: missing input exits 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/nope.pmap"
check "...naming it" grep -q "nope.pmap" "$tmp/err"
check "...in one line" one_line
check "...and writes nothing" test ! -e "$tmp/x.pmap"
check "pm-inspect: missing map exits 1" status 1 $INS "$tmp/nope.pmap"
check "...naming it" grep -q "nope.pmap" "$tmp/err"
check "pm-inspect: a scene is not a map, exit 1" status 1 $INS "$scene"
check "...naming it" grep -q "cornell-box.xml" "$tmp/err"

# --- Maps to work on: one run of 6000 paths, and the same in two shards ---
check "pm-shoot makes a whole map" status 0 $SHOOT "$scene" -q --seed 3 --photons 6000 -o "$tmp/all.pmap"
check "pm-shoot makes shard a: paths [0, 2500)" status 0 $SHOOT "$scene" -q --seed 3 --photons 2500 -o "$tmp/a.pmap"
check "pm-shoot makes shard b: paths [2500, 6000)" status 0 $SHOOT "$scene" -q --seed 3 --photons 3500 --first-index 2500 -o "$tmp/b.pmap"

head -c 300 "$tmp/all.pmap" >"$tmp/trunc.pmap"
check "pm-inspect: truncated map exits 1" status 1 $INS "$tmp/trunc.pmap"
check "...naming it" grep -q "trunc.pmap" "$tmp/err"
check "...in one line" one_line
check "pm-balance: truncated input exits 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/a.pmap" "$tmp/trunc.pmap"
check "...naming it" grep -q "trunc.pmap" "$tmp/err"
cp "$tmp/all.pmap" "$tmp/flip.pmap"
python3 -c 'import sys; p = sys.argv[1]; b = bytearray(open(p, "rb").read()); b[-7] ^= 0x40; open(p, "wb").write(b)' "$tmp/flip.pmap"
check "pm-inspect: a flipped photon bit exits 1 (crc32)" status 1 $INS "$tmp/flip.pmap"
check "...naming the file" grep -q "flip.pmap" "$tmp/err"

# --- Merging ---
check "balancing the whole run succeeds" status 0 $BAL -q -o "$tmp/whole.pmap" "$tmp/all.pmap"
check "...leaving no temporary file behind" test "$(ls "$tmp" | grep -c '^whole\.pmap.')" -eq 0
check "merging shards a b succeeds" status 0 $BAL -q -o "$tmp/ab.pmap" "$tmp/a.pmap" "$tmp/b.pmap"
check "...into the photons of the whole run, bit for bit" same_content "$tmp/whole.pmap" "$tmp/ab.pmap"
check "merging them in reverse order succeeds" status 0 $BAL -q -o "$tmp/ba.pmap" "$tmp/b.pmap" "$tmp/a.pmap"
check "...into the same photons" same_content "$tmp/whole.pmap" "$tmp/ba.pmap"
check "...printed in full by --dump csv, identical" sh -c "$INS --dump csv $tmp/whole.pmap >$tmp/w.csv && $INS --dump csv $tmp/ba.pmap >$tmp/ba.csv && cmp -s $tmp/w.csv $tmp/ba.csv"
check "the emitted counts add up" test "$(key "$tmp/ab.pmap" global.emitted)" -eq 6000
check "the photon counts add up" test "$(key "$tmp/ab.pmap" global.photons)" -eq $(($(key "$tmp/a.pmap" global.photons) + $(key "$tmp/b.pmap" global.photons)))
check "the first index is the smallest" test "$(key "$tmp/ba.pmap" global.first_index)" -eq 0
check "the provenance names the inputs" sh -c "$INS $tmp/ba.pmap | grep -q '^info	input	.*a.pmap'"
$BAL -q -o "$tmp/a.bal" "$tmp/a.pmap" && $BAL -q -o "$tmp/b.bal" "$tmp/b.pmap"
check "merging balanced shards succeeds" status 0 $BAL -q -o "$tmp/abb.pmap" "$tmp/b.bal" "$tmp/a.bal"
check "...into the same photons" same_content "$tmp/whole.pmap" "$tmp/abb.pmap"
rebalance_same() {
	$BAL -q -o "$tmp/again.pmap" "$tmp/whole.pmap" &&
	    $INS --dump csv "$tmp/again.pmap" >"$tmp/again.csv" &&
	    cmp -s "$tmp/w.csv" "$tmp/again.csv"
}
check "balancing a balanced map changes no photon" rebalance_same
check "1 and 2 threads give the same photons" sh -c "$BAL -q -t 1 -o $tmp/t1.pmap $tmp/all.pmap && $BAL -q -t 2 -o $tmp/t2.pmap $tmp/all.pmap"
check "...(compared)" same_content "$tmp/t1.pmap" "$tmp/t2.pmap"
check "--compress writes a smaller file" sh -c "$BAL -q --compress -o $tmp/z.pmap $tmp/a.pmap $tmp/b.pmap && test \$(wc -c <$tmp/z.pmap) -lt \$(wc -c <$tmp/ab.pmap)"
check "...holding the same photons" same_content "$tmp/z.pmap" "$tmp/ab.pmap"
if [ -f "$caustic_scene" ]; then
	$SHOOT "$caustic_scene" -q --photons 1500 --caustic-photons 1500 -o "$tmp/c.pmap"
	$SHOOT "$caustic_scene" -q --photons 600 --caustic-photons 600 -o "$tmp/c1.pmap"
	$SHOOT "$caustic_scene" -q --photons 900 --caustic-photons 900 --first-index 600 -o "$tmp/c2.pmap"
	$BAL -q -o "$tmp/cw.pmap" "$tmp/c.pmap"
	check "two-map shards merge too" status 0 $BAL -q -o "$tmp/cm.pmap" "$tmp/c2.pmap" "$tmp/c1.pmap"
	check "...into the photons of the whole run" same_content "$tmp/cw.pmap" "$tmp/cm.pmap"
	check "...caustic map included" sh -c "$INS $tmp/cm.pmap | grep -q '^caustic.records_crc32'"
	check "pm-inspect --map caustic reports that map only" sh -c "$INS --map caustic $tmp/cm.pmap | grep -q '^caustic.photons' && ! $INS --map caustic $tmp/cm.pmap | grep -q '^global.'"
	$SHOOT "$caustic_scene" -q --photons 500 --caustic-photons 0 --first-index 1500 -o "$tmp/c3.pmap"
	check "a shard without the caustic map is refused, exit 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/c1.pmap" "$tmp/c3.pmap"
	check "...naming both files and the maps" sh -c "grep -q 'c1.pmap' $tmp/err && grep -q 'c3.pmap' $tmp/err && grep -q caustic $tmp/err"
fi

# --- Refusals ---
$SHOOT "$scene" -q --seed 4 --photons 1000 --first-index 6000 -o "$tmp/seed4.pmap"
check "shards of different seeds are refused, exit 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/all.pmap" "$tmp/seed4.pmap"
check "...naming both files and the seed" sh -c "grep -q 'seed4.pmap' $tmp/err && grep -q 'all.pmap' $tmp/err && grep -q seed $tmp/err"
check "...in one line" one_line
check "...writing nothing" test ! -e "$tmp/x.pmap"
$SHOOT "$scene2" -q --seed 3 --photons 1000 --first-index 6000 -o "$tmp/other.pmap"
check "shards of different scenes are refused, exit 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/all.pmap" "$tmp/other.pmap"
check "...naming both files and the scene" sh -c "grep -q 'other.pmap' $tmp/err && grep -q 'all.pmap' $tmp/err && grep -q scene $tmp/err"
check "overlapping shards are refused, exit 1" status 1 $BAL -o "$tmp/x.pmap" "$tmp/a.pmap" "$tmp/all.pmap"
check "...saying so" grep -q "overlap" "$tmp/err"
check "a shard given twice is refused" status 1 $BAL -o "$tmp/x.pmap" "$tmp/a.pmap" "$tmp/a.pmap"
cp "$tmp/ab.pmap" "$tmp/keep.pmap"
check "an existing output without -f is refused, exit 1" status 1 $BAL -o "$tmp/ab.pmap" "$tmp/all.pmap"
check "...saying so" grep -q "exists" "$tmp/err"
check "...and leaving it as it was" cmp -s "$tmp/ab.pmap" "$tmp/keep.pmap"
check "-f overwrites it" status 0 $BAL -q -f -o "$tmp/ab.pmap" "$tmp/all.pmap"
check "...with the new map" sh -c "$INS $tmp/ab.pmap | grep -q '^info	input	.*all.pmap'"
check "an unwritable output directory exits 1" status 1 $BAL -o "$tmp/no/such/dir/x.pmap" "$tmp/all.pmap"
check "...naming it" grep -q "no/such/dir" "$tmp/err"

# --- Pipes ---
check "pm-shoot -o - | pm-balance - works" sh -c "$SHOOT $scene -q --seed 3 --photons 6000 -o - | $BAL -q -o $tmp/p.pmap -"
# To a file the maps are written as they are shot; to a pipe, or
# compressed, they are held and written at the end: the same photons.
check "pm-shoot to a file (streamed, 2 threads) and to a pipe (1 thread) agree" sh -c "$SHOOT $caustic_scene -q -t 2 --seed 5 --photons 20000 --caustic-photons 9000 -o $tmp/sf.pmap && $SHOOT $caustic_scene -q -t 1 --seed 5 --photons 20000 --caustic-photons 9000 -o - >$tmp/sp.pmap"
check "...photon for photon" same_content "$tmp/sf.pmap" "$tmp/sp.pmap"
check "...in both maps" grep -q '^caustic.records_crc32' "$tmp/c1"
# A map is written for the whole run; a run killed meanwhile leaves no
# file, complete or temporary (the temporary file has no name until it is
# complete, where the file system allows).
mkdir -p "$tmp/kill"
if python3 -c 'import os, sys; os.close(os.open(sys.argv[1], os.O_TMPFILE | os.O_WRONLY))' "$tmp/kill" 2>/dev/null; then
	$SHOOT $scene -q -t 2 --photons 40000000 -o "$tmp/kill/k.pmap" 2>/dev/null &
	kpid=$!
	sleep 1
	kill -TERM $kpid 2>/dev/null
	wait $kpid 2>/dev/null
	check "a pm-shoot killed while writing leaves no file behind" test "$(ls -A "$tmp/kill" | wc -l)" -eq 0
else
	skip "a pm-shoot killed while writing leaves no file behind: no O_TMPFILE here"
fi
check "compressed (held) too" status 0 $SHOOT $caustic_scene -q -t 2 --seed 5 --photons 20000 --caustic-photons 9000 --compress -o "$tmp/sz.pmap"
check "...photon for photon" same_content "$tmp/sf.pmap" "$tmp/sz.pmap"
check "...giving the photons of the whole run" same_content "$tmp/whole.pmap" "$tmp/p.pmap"
check "a shard on standard input merges with files" sh -c "$BAL -q -o $tmp/pm.pmap $tmp/a.pmap - <$tmp/b.pmap"
check "...into the same photons" same_content "$tmp/whole.pmap" "$tmp/pm.pmap"
check "pm-balance -o - | pm-inspect - works" sh -c "$BAL -q -o - $tmp/a.pmap $tmp/b.pmap | $INS - >$tmp/pipe.txt"
check "...reporting the photons" grep -q "^global.emitted	6000\$" "$tmp/pipe.txt"
check "garbage on standard input exits 1" sh -c "echo garbage | $BAL -o $tmp/x.pmap - 2>/dev/null; test \$? -eq 1"

# --- The report ---
check "pm-inspect succeeds" status 0 $INS "$tmp/all.pmap"
check "...and is key<TAB>value lines" sh -c "awk -F'\t' 'NF < 2 { exit 1 }' $tmp/out"
check "...reporting the emitted photon paths" grep -q "^global.emitted	6000\$" "$tmp/out"
check "...and the first index" test "$(key "$tmp/b.pmap" global.first_index)" -eq 2500
check "...and the seed" grep -q "^seed	3\$" "$tmp/out"
check "...and that the map is not balanced" grep -q "^global.balanced	false\$" "$tmp/out"
check "...and that the merged one is" test "$(key "$tmp/whole.pmap" global.balanced)" = true
check "...with a depth histogram that sums to the photons" test "$($INS "$tmp/all.pmap" | awk -F'\t' '$1 ~ /^global\.depth\./ { s += $2 } END { print s }')" -eq "$(key "$tmp/all.pmap" global.photons)"
check "...and a positive flux" sh -c "$INS $tmp/all.pmap | awk -F'\t' '\$1 == \"global.flux\" && \$2 > 0 && \$3 > 0 && \$4 > 0 { ok = 1 } END { exit !ok }'"
check "...and pm-shoot's provenance" grep -q "^info	tool	pm-shoot" "$tmp/out"
check "--json output parses" sh -c "$INS --json $tmp/ab.pmap | python3 -c 'import json,sys; json.load(sys.stdin)'"
check "...with the same counts" sh -c "$INS --json $tmp/whole.pmap | python3 -c 'import json,sys; d = json.load(sys.stdin); m = d[\"maps\"][0]; assert m[\"emitted\"] == 6000 and sum(m[\"depth\"]) == m[\"photons\"] == d[\"photons\"]'"
check "--json with the checks parses" sh -c "$INS --json --verify --knn-check 50 -k 8 $tmp/whole.pmap | python3 -c 'import json,sys; d = json.load(sys.stdin); assert d[\"maps\"][0][\"knn_check\"][\"mismatches\"] == 0 and d[\"maps\"][0][\"kdtree\"] == \"ok\"'"

# --- Checks ---
check "--verify passes on a balanced map" status 0 $INS --verify "$tmp/whole.pmap"
check "...saying so" sh -c "grep -q '^global.kdtree	ok\$' $tmp/out && grep -q '^crc32	ok\$' $tmp/out"
check "--verify on an unbalanced map exits 0" status 0 $INS --verify "$tmp/all.pmap"
check "...saying there is no tree" grep -q "^global.kdtree	not balanced\$" "$tmp/out"
cp "$tmp/whole.pmap" "$tmp/broken.pmap"
if break_order "$tmp/broken.pmap"; then
	check "a map whose kd order is broken reads cleanly" status 0 $INS "$tmp/broken.pmap"
	check "--verify fails on it, exit 1" status 1 $INS --verify "$tmp/broken.pmap"
	check "...naming the node" grep -q "node [0-9]" "$tmp/err"
	check "...and the file" grep -q "broken.pmap" "$tmp/err"
else
	check "the broken-order map was made" false
fi
check "--knn-check succeeds" status 0 $INS --knn-check 300 "$tmp/whole.pmap"
check "...with 0 mismatches" grep -q "^global.knn.mismatches	0\$" "$tmp/out"
check "...over the queries asked" grep -q "^global.knn.queries	300\$" "$tmp/out"
check "...with both rates and their ratio" sh -c "grep -q '^global.knn.pm_qps' $tmp/out && grep -q '^global.knn.flann_qps' $tmp/out && grep -q '^global.knn.speedup' $tmp/out"
check "--knn-check -k 1 succeeds" status 0 $INS --knn-check 100 -k 1 --seed 9 "$tmp/whole.pmap"
check "--knn-check on an unbalanced map exits 1" status 1 $INS --knn-check 10 "$tmp/all.pmap"
check "...saying why" grep -q "balance" "$tmp/err"
cp "$tmp/whole.pmap" "$tmp/reversed.pmap"
if break_order "$tmp/reversed.pmap" reverse; then
	check "--knn-check finds mismatches in a scrambled tree, exit 1" status 1 $INS --knn-check 300 "$tmp/reversed.pmap"
	check "...saying how many" grep -q "differ from FLANN" "$tmp/err"
	check "...and reporting them" sh -c "awk -F'\t' '\$1 == \"global.knn.mismatches\" && \$2 > 0 { ok = 1 } END { exit !ok }' $tmp/out"
else
	check "the scrambled map was made" false
fi
check "--map caustic on a map without one exits 1" status 1 $INS --map caustic "$tmp/whole.pmap"

# --- Dumps ---
np=$(key "$tmp/whole.pmap" global.photons)
check "--dump ply succeeds" status 0 $INS --dump ply "$tmp/whole.pmap"
check "...with a vertex per photon" grep -q "^element vertex $np\$" "$tmp/out"
check "...and that many vertices" test "$(sed '1,/^end_header$/d' "$tmp/out" | wc -l)" -eq "$np"
check "...each 3 floats and 3 bytes" sh -c "sed '1,/^end_header\$/d' $tmp/out | awk 'NF != 6 || \$4 > 255 || \$5 > 255 || \$6 > 255 || \$4 < 0 { exit 1 }'"
check "...not all black" sh -c "sed '1,/^end_header\$/d' $tmp/out | awk '\$4 + \$5 + \$6 > 0 { ok = 1 } END { exit !ok }'"
check "--dump xyz has a line per photon" sh -c "test \$($INS --dump xyz $tmp/whole.pmap | wc -l) -eq $np"
check "--dump csv has a header and a line per photon" sh -c "test \$($INS --dump csv $tmp/whole.pmap | wc -l) -eq $((np + 1))"
flux_sums() { # the csv fluxes add up to the report's red flux
	f=$(key "$tmp/whole.pmap" global.flux)
	$INS --dump csv "$tmp/whole.pmap" | awk -F, -v f="$f" \
	    'NR > 1 { s += $5 } END { d = s - f; if (d < 0) d = -d; exit !(f > 0 && d <= 1e-4 * f) }'
}
check "...whose fluxes sum to the reported flux" flux_sums

# --- Irradiance maps (kind 3), which pm-balance will make ---
if add_irradiance "$tmp/whole.pmap" "$tmp/irr.pmap" 0.0625; then
	ng=$(key "$tmp/whole.pmap" global.photons)
	check "pm-inspect reads a map with an irradiance map" status 0 $INS --verify "$tmp/irr.pmap"
	check "...naming its kind and records" grep -q "^irradiance.records	$ng\$" "$tmp/out"
	check "...its radius" grep -q "^irradiance.radius	0.0625\$" "$tmp/out"
	check "...its mean and largest irradiance" sh -c "awk -F'\t' '\$1 == \"irradiance.mean_irradiance\" && \$2 > 0 { m = 1 } \$1 == \"irradiance.max_irradiance\" && \$2 > 0 { x = 1 } END { exit !(m && x) }' $tmp/out"
	check "...no flux, emitted count or depths, which it has not" sh -c "! grep -q -e '^irradiance.flux' -e '^irradiance.emitted' -e '^irradiance.depth' -e '^irradiance.photons' $tmp/out"
	check "...its kd-tree order" grep -q "^irradiance.kdtree	ok\$" "$tmp/out"
	check "...counting photons without the records" grep -q "^photons	$ng\$" "$tmp/out"
	check "...and the global map as before" sh -c "$INS $tmp/whole.pmap | grep '^global\.' >$tmp/g1 && grep '^global\.' $tmp/out | grep -v kdtree >$tmp/g2 && cmp -s $tmp/g1 $tmp/g2"
	check "--map irradiance reports that map only" sh -c "$INS --map irradiance $tmp/irr.pmap >$tmp/o2 && grep -q '^irradiance.records' $tmp/o2 && ! grep -q '^global\.' $tmp/o2"
	check "--map irradiance on a map without one exits 1" status 1 $INS --map irradiance "$tmp/whole.pmap"
	check "--json names the kind, records and radius" sh -c "$INS --json $tmp/irr.pmap | python3 -c 'import json,sys; d = json.load(sys.stdin); m = d[\"maps\"][1]; assert m[\"kind\"] == \"irradiance\" and m[\"records\"] == $ng and m[\"radius\"] == 0.0625 and \"flux\" not in m and d[\"photons\"] == $ng'"
	check "--dump csv has a line per photon and record" sh -c "test \$($INS --dump csv $tmp/irr.pmap | wc -l) -eq $((2 * ng + 1))"
	check "...the records without a direction, with a normal" sh -c "$INS --dump csv $tmp/irr.pmap | awk -F, '\$1 == \"irradiance\" { r++; if (\$8 != \"\" || \$13 == \"\") bad = 1 } END { exit bad || !r }'"
	check "--knn-check runs on the irradiance map too" status 0 $INS --knn-check 50 --map irradiance "$tmp/irr.pmap"
	check "pm-balance drops an input's irradiance map" status 0 $BAL -o "$tmp/irr-bal.pmap" "$tmp/irr.pmap"
	check "...with one note saying so" sh -c "test \$(wc -l <$tmp/err) -eq 1 && grep -q 'irr.pmap: note: its irradiance map ($ng records) is dropped, not merged' $tmp/err"
	check "...keeping the photons as they were" same_content "$tmp/whole.pmap" "$tmp/irr-bal.pmap"
	check "...and no irradiance map" sh -c "! $INS $tmp/irr-bal.pmap | grep -q '^irradiance'"
	$SHOOT "$scene" -q --seed 3 --photons 1000 --first-index 6000 -o "$tmp/next.pmap"
	check "...merging it with a shard that has none" status 0 $BAL -q -f -o "$tmp/irr-bal.pmap" "$tmp/irr.pmap" "$tmp/next.pmap"
	check "...-q silencing the note" test ! -s "$tmp/err"
	check "...into photons of paths [0, 7000)" test "$(key "$tmp/irr-bal.pmap" global.emitted)" -eq 7000
	check "pm-render renders with a map that has irradiance records" status 0 $BIN/pm-render -q --spp 1 --size 8x8 -o "$tmp/irr.exr" "$scene" "$tmp/irr.pmap"
else
	check "the map with an irradiance map was made" false
fi

# --- The irradiance records pm-balance makes by default ---
check "pm-balance makes irradiance records by default" status 0 $BALI -v -o "$tmp/rec.pmap" "$tmp/all.pmap"
ng=$(key "$tmp/whole.pmap" global.photons)
check "...one per 8 global photons" test "$(key "$tmp/rec.pmap" irradiance.records)" -eq $((ng / 8))
check "...saying so with -v" grep -q "irradiance map: $((ng / 8)) records, one per 8 global photons" "$tmp/err"
check "...in kd-tree order, with a radius" sh -c "$INS --verify $tmp/rec.pmap >$tmp/o3 && grep -q '^irradiance.kdtree	ok\$' $tmp/o3 && awk -F'\t' '\$1 == \"irradiance.radius\" && \$2 > 0 { ok = 1 } END { exit !ok }' $tmp/o3"
check "...of positive mean irradiance" sh -c "awk -F'\t' '\$1 == \"irradiance.mean_irradiance\" && \$2 > 0 { ok = 1 } END { exit !ok }' $tmp/o3"
check "...and the same global map as without them" sh -c "$INS $tmp/whole.pmap | grep '^global\.' >$tmp/g1 && $INS $tmp/rec.pmap | grep '^global\.' >$tmp/g2 && cmp -s $tmp/g1 $tmp/g2"
check "balancing it again gives the same records" sh -c "$BALI -q -o $tmp/rec2.pmap $tmp/rec.pmap && $INS --map irradiance $tmp/rec.pmap | grep -v -e '^file' -e '^info' >$tmp/r1 && $INS --map irradiance $tmp/rec2.pmap | grep -v -e '^file' -e '^info' >$tmp/r2 && cmp -s $tmp/r1 $tmp/r2"
same_records() { # 1 and 2 threads: the same map contents, records included
	$BALI -q -t 1 -o "$tmp/rt1.pmap" "$tmp/all.pmap" &&
	    $BALI -q -t 2 -o "$tmp/rt2.pmap" "$tmp/all.pmap" &&
	    same_content "$tmp/rt1.pmap" "$tmp/rt2.pmap" &&
	    grep -q '^irradiance.records_crc32' "$tmp/c1"
}
check "1 and 2 threads give the same records" same_records
check "--irradiance-stride 16 makes half as many" sh -c "$BALI -q --irradiance-stride 16 -o $tmp/r16.pmap $tmp/all.pmap && test \$($INS $tmp/r16.pmap | awk -F'\t' '\$1 == \"irradiance.records\" { print \$2 }') -eq $((ng / 16))"
r1=$(key "$tmp/rec.pmap" irradiance.radius)
check "--pass 9 computes them over a smaller fixed radius" sh -c "$BALI -q --pass 9 -o $tmp/p9.pmap $tmp/all.pmap && $BALI -q --pass 1 -o $tmp/p1.pmap $tmp/all.pmap && awk -v a=\$($INS $tmp/p1.pmap | awk -F'\t' '\$1 == \"irradiance.radius\" { print \$2 }') -v b=\$($INS $tmp/p9.pmap | awk -F'\t' '\$1 == \"irradiance.radius\" { print \$2 }') -v c=$r1 'BEGIN { exit !(b < a && a == c) }'"
check "--irradiance-stride x is a usage error" status 2 $BALI --irradiance-stride x -o "$tmp/x.pmap" "$tmp/all.pmap"
check "pm-render uses the records" status 0 $BIN/pm-render -q --spp 1 --size 8x8 -o "$tmp/rec.exr" "$scene" "$tmp/rec.pmap"

finish photon
