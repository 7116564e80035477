#!/bin/sh
# bench.sh: pm's speed, measured; `make bench` runs it from the repository
# root after building bin/ and build/tests/bench (tests/bench/bench.c).
#
#   - kd-tree build time and k-nearest queries per second, k = 50 and 200,
#     on 1M and 10M photons shot in data/cornell-box.xml, against FLANN on
#     the same photons (pm_knn_check, one thread each, the queries given
#     to both as one batch; pm also one query a call), as ratios; FLANN's
#     build both on pm's tree order (pm_knn_check's) and on the file's
#     order, which is what pm's build gets; and the build's speed-up from
#     one thread to every core;
#   - fixed-radius queries per second (the walk of progressive passes) on
#     1M photons, with the radii of the 50th and 200th neighbours;
#   - photon paths and stored photons per second per core (pm-shoot -t 1)
#     against a plain loop of Embree closest-hit ray casts from the lights
#     of the same scene on one core (the ceiling for photon tracing); and
#     the photon pass's own rays cast alone, in its own packets (bench
#     casts), which says how much of photon tracing is Embree's and bounds
#     the ratio above, and the same pass in memory, without the map's
#     file (its box, checksum and write);
#   - the parallel speed-up from 1 thread to every core of pm-shoot,
#     pm-balance and pm-render (the render twice: 128x128 at 16 spp, where
#     the serial start is a tenth of the run, and 256x256 at 64 spp; each
#     also for its render stage alone, as pm-render -v times it);
#   - peak resident memory of pm-shoot and pm-balance (one thread,
#     caustics.xml, 5M paths) against the size of the map they write;
#   - the map's CRC-32 on each path the CPU has (zlib, PCLMULQDQ,
#     VPCLMULQDQ), in cache and from memory, one core;
#   - bytes per photon in memory and on disk, plain and zlib-compressed;
#   - camera paths per second on one core in path mode against Mitsuba 3's
#     path tracer (tests/bench/mitsuba_paths.py, from the accuracy venv).
#
# One table on stdout, every figure as JSON in out/bench/bench.json.  No
# figure passes or fails: the machine decides them.  Knobs (environment):
# BENCH_BIG (10000000 photons), BENCH_QUERIES (20000 per k),
# BENCH_SPEEDUP_RUNS (3: the speed-up rows, the kd-tree build's too, take
# the best of as many, run in turns),
# BENCH_PATH_RUNS (3: so do both sides of the camera-paths rows),
# BENCH_SHOOT_RUNS (3: and of the rows of photons against the ceiling),
# BENCH_FLANN_FILE_ORDER_MAX (2000000: FLANN's build on the file's order,
# the input pm's build gets, is timed up to this many photons; 1e7 adds
# the 10M row, at 7 s to 27 s of FLANN).

set -eu

B=${BIN:-bin}
X=${BENCH:-build/tests/bench}
OUT=out/bench
BIG=${BENCH_BIG:-10000000}
Q=${BENCH_QUERIES:-20000}
NCPU=$(getconf _NPROCESSORS_ONLN)
mkdir -p "$OUT"
J=$OUT/bench.jsonl
: >"$J"

now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.3f", b - a }'; }
key() { $B/pm-inspect "$1" | awk -F'\t' -v k="$2" '$1 == k { print $2 }'; }
emit() { printf '%s\n' "$1" >>"$J"; }

scene=data/cornell-box.xml
# Paths enough for BIG stored photons: the box stores about 1.85 per path.
paths=$(awk -v n="$BIG" 'BEGIN { printf "%d", n / 1.8 + 1 }')
t=$(now)
$B/pm-shoot -q -f --photons "$paths" -o "$OUT/big.pmap" $scene
emit "{\"what\": \"shoot-big\", \"paths\": $paths, \"photons\": $(key $OUT/big.pmap global.photons), \"seconds\": $(since "$t")}"
for n in 1000000 "$BIG"; do
	$X knn "$OUT/big.pmap" "$n" 50,200 "$Q" | while read -r line; do
		emit "{\"what\": \"knn\", ${line#\{}"
	done
done
# Fixed-radius queries (progressive passes), one radius per k: the median
# distance to the k-th nearest photon.
$X range "$OUT/big.pmap" 1000000 50,200 "$Q" | while read -r line; do
	emit "{\"what\": \"range\", ${line#\{}"
done
rm -f "$OUT/big.pmap"

# Photon tracing against the ray-cast ceiling, one core each: each side
# the best of BENCH_SHOOT_RUNS runs, in turns (pm-shoot, the ceiling for
# a second, ...), as for the speed-ups below; one run each read the
# bunny's row 0.59 and 0.64 in two runs of the bench at one commit.
SR=${BENCH_SHOOT_RUNS:-3}
for s in cornell-box bunny; do
	pps=0
	rays=
	best=0
	i=0
	while [ "$i" -lt "$SR" ]; do
		$B/pm-shoot -v -f -t 1 --photons 1000000 -o "$OUT/s1.pmap" \
		    data/$s.xml 2>"$OUT/shoot.log"
		p=$(sed -n 's/.*global map: .* (\([0-9.]*\) paths\/s), \([0-9]*\) photons stored.*/\1/p' "$OUT/shoot.log")
		pps=$(awk -v a="$pps" -v b="$p" 'BEGIN { print (b > a ? b : a) }')
		x=$($X rays data/$s.xml 1)
		v=$(printf '%s\n' "$x" | sed -n 's/.*"rays_per_s": \([0-9.]*\).*/\1/p')
		if awk -v a="$best" -v b="$v" 'BEGIN { exit !(b > a) }'; then
			best=$v
			rays=$x
		fi
		i=$((i + 1))
	done
	stored=$(key "$OUT/s1.pmap" global.photons)
	# The same pass's own rays cast alone, in the same calls (packets of
	# a round's rays): how much of it is Embree's, and what the row
	# above would read if pm's own work cost nothing.
	casts=$($X casts data/$s.xml 1000000)
	emit "{\"what\": \"shoot-vs-rays\", \"scene\": \"$s\", \"paths_per_s\": $pps, \"photons_per_path\": $(awk -v a="$stored" 'BEGIN { print a / 1000000 }'), \"rays\": $rays, \"casts\": $casts}"
done

# Speed-up from one thread to all, on the same work: each side the best
# of BENCH_SPEEDUP_RUNS runs, taken in turns (1, all, 1, all, ...), so
# that a neighbour's burst on this shared machine does not decide the
# ratio (one run each gave pm-render anything from 1.6x to 1.9x).
R=${BENCH_SPEEDUP_RUNS:-3}
# Seconds of the fastest of R runs of each of two commands, in turns.
best2() {
	ba=; bb=
	i=0
	while [ "$i" -lt "$R" ]; do
		t=$(now); eval "$1"; x=$(since "$t")
		t=$(now); eval "$2"; y=$(since "$t")
		ba=$(awk -v a="${ba:-$x}" -v b="$x" 'BEGIN { print (b < a ? b : a) }')
		bb=$(awk -v a="${bb:-$y}" -v b="$y" 'BEGIN { print (b < a ? b : a) }')
		i=$((i + 1))
	done
	echo "$ba $bb"
}
# pm-render's, and the render stage's seconds of each command's fastest
# stage, as -v prints them ("rendered N samples in S s", after loading):
# what the threads can do, against what the whole process shows.
stage() { sed -n 's/.*rendered [0-9]* samples in \([0-9.]*\) s.*/\1/p' "$1"; }
lesser() { awk -v a="${1:-$2}" -v b="$2" 'BEGIN { print (b < a ? b : a) }'; }
best2_render() {
	ba=; bb=; sa=; sb=
	i=0
	while [ "$i" -lt "$R" ]; do
		t=$(now); eval "$1" 2>"$OUT/r1.log"; x=$(since "$t")
		t=$(now); eval "$2" 2>"$OUT/rN.log"; y=$(since "$t")
		ba=$(lesser "$ba" "$x"); bb=$(lesser "$bb" "$y")
		sa=$(lesser "$sa" "$(stage "$OUT/r1.log")")
		sb=$(lesser "$sb" "$(stage "$OUT/rN.log")")
		i=$((i + 1))
	done
	rm -f "$OUT/r1.log" "$OUT/rN.log"
	echo "$ba $bb $sa $sb"
}
set -- $(best2 \
    '$B/pm-shoot -q -f -t 1 --photons 1000000 -o "$OUT/s1.pmap" $scene' \
    '$B/pm-shoot -q -f -t "$NCPU" --photons 1000000 -o "$OUT/sN.pmap" $scene')
emit "{\"what\": \"speedup\", \"tool\": \"pm-shoot\", \"threads\": $NCPU, \"one_s\": $1, \"all_s\": $2, \"runs\": $R}"
set -- $(best2 \
    '$B/pm-balance -q -f -t 1 -o "$OUT/b1.pmap" "$OUT/s1.pmap"' \
    '$B/pm-balance -q -f -t "$NCPU" -o "$OUT/bN.pmap" "$OUT/s1.pmap"')
emit "{\"what\": \"speedup\", \"tool\": \"pm-balance\", \"threads\": $NCPU, \"one_s\": $1, \"all_s\": $2, \"runs\": $R}"
# 16 spp: at 4 the whole run took 0.1 s, a third of it the serial start
# (reading and checking the map, the irradiance grid), which decided the
# ratio (1.41x) more than the render did.
set -- $(best2_render \
    '$B/pm-render -v -f -t 1 --spp 16 --size 128x128 -o "$OUT/r1.exr" $scene "$OUT/bN.pmap"' \
    '$B/pm-render -v -f -t "$NCPU" --spp 16 --size 128x128 -o "$OUT/rN.exr" $scene "$OUT/bN.pmap"')
emit "{\"what\": \"speedup\", \"tool\": \"pm-render\", \"work\": \"128x128, 16 spp\", \"threads\": $NCPU, \"one_s\": $1, \"all_s\": $2, \"one_stage_s\": $3, \"all_stage_s\": $4, \"runs\": $R}"
# The same at 256x256, 64 spp (16 times the samples): on a quiet machine
# the run above takes 0.16 s on one thread, of which the serial start
# (starting, mapping and checking the map, the irradiance grid) and the
# image's write are a tenth; a render a user waits for (the demo: 1024x1024,
# 16 spp) is seconds to minutes, where they are nothing.
set -- $(best2_render \
    '$B/pm-render -v -f -t 1 --spp 64 --size 256x256 -o "$OUT/r1.exr" $scene "$OUT/bN.pmap"' \
    '$B/pm-render -v -f -t "$NCPU" --spp 64 --size 256x256 -o "$OUT/rN.exr" $scene "$OUT/bN.pmap"')
emit "{\"what\": \"speedup\", \"tool\": \"pm-render\", \"work\": \"256x256, 64 spp\", \"threads\": $NCPU, \"one_s\": $1, \"all_s\": $2, \"one_stage_s\": $3, \"all_stage_s\": $4, \"runs\": $R}"

# Camera paths per second on one core, path mode, against Mitsuba 3's
# path tracer on the same scene file (same max_depth and spp), where the
# accuracy venv (make accuracy-venv) has it: the render's own rate as
# pm-render -v prints it against Mitsuba's render call, loading excluded
# from both.  Each side the fastest of BENCH_PATH_RUNS (3) renders, pm's
# one before and the rest after Mitsuba's (whose renders share one
# process: a process is 2 s of Python and Dr.Jit before its first
# sample); one run each moved the ratio by a fifth between runs of the
# bench.
PY=${BENCH_PY:-build/venv/bin/python}
PIN=
command -v taskset >/dev/null 2>&1 && PIN="taskset -c 0"
PR=${BENCH_PATH_RUNS:-3}
# pm-render's camera paths per second (M), one run.
pm_paths() {
	$PIN $B/pm-render -v -f -t 1 --method path --spp 64 --size 128x128 \
	    -D res=128 -o "$OUT/p.exr" data/$1.xml 2>"$OUT/path.log"
	sed -n 's/.*rendered [0-9]* samples in [0-9.]* s (\([0-9.]*\) Msamples\/s).*/\1/p' "$OUT/path.log"
}
for s in cornell-box caustics; do
	pm=$(pm_paths $s)
	mi=null
	if [ -x "$PY" ] && "$PY" -c 'import mitsuba' 2>/dev/null; then
		mi=$($PIN "$PY" tests/bench/mitsuba_paths.py data/$s.xml 128 64 \
		    llvm_ad_rgb "$PR" |
		    sed -n 's/.*"samples_per_s": \([0-9.e+]*\).*/\1/p')
		[ -n "$mi" ] || mi=null
	fi
	i=1
	while [ "$i" -lt "$PR" ]; do
		pm=$(awk -v a="$pm" -v b="$(pm_paths $s)" 'BEGIN { print (b > a ? b : a) }')
		i=$((i + 1))
	done
	emit "{\"what\": \"paths\", \"scene\": \"$s\", \"pm_samples_per_s\": $(awk -v m="$pm" 'BEGIN { print m * 1e6 }'), \"mitsuba_samples_per_s\": $mi}"
done
rm -f "$OUT/path.log"

# Peak resident memory of pm-shoot and pm-balance against the map they
# write (GNU time's %M, in KiB), one thread, caustics.xml.
if /usr/bin/time -f %M true >/dev/null 2>&1; then
	/usr/bin/time -f %M -o "$OUT/rss" $B/pm-shoot -q -f -t 1 --photons 4000000 \
	    --caustic-photons 1000000 -o "$OUT/m.pmap" data/caustics.xml
	emit "{\"what\": \"rss\", \"tool\": \"pm-shoot\", \"max_rss_kib\": $(tail -n 1 "$OUT/rss"), \"map_bytes\": $(key $OUT/m.pmap file_bytes)}"
	/usr/bin/time -f %M -o "$OUT/rss" $B/pm-balance -q -f -t 1 -o "$OUT/mb.pmap" \
	    "$OUT/m.pmap"
	emit "{\"what\": \"rss\", \"tool\": \"pm-balance\", \"max_rss_kib\": $(tail -n 1 "$OUT/rss"), \"map_bytes\": $(key $OUT/mb.pmap file_bytes)}"
	rm -f "$OUT/rss"
fi

# The map's CRC-32 on each path the CPU has, one core.
$PIN $X crc | while read -r line; do
	emit "{\"what\": \"crc\", ${line#\{}"
done

# Bytes per photon.
$B/pm-balance -q -f --compress -o "$OUT/bz.pmap" "$OUT/s1.pmap"
emit "{\"what\": \"bytes\", \"photons\": $(key $OUT/bN.pmap photons), \"disk_bytes\": $(key $OUT/bN.pmap file_bytes), \"compressed_bytes\": $(key $OUT/bz.pmap file_bytes), $($X sizes | sed 's/^{//')"
rm -f "$OUT"/*.pmap "$OUT"/*.exr "$OUT/shoot.log"

# The table, and the JSON as one document.
python3 - "$J" "$OUT/bench.json" <<'PY'
import json, os, platform, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
cpu = ""
try:
    for l in open("/proc/cpuinfo"):
        if l.startswith("model name"):
            cpu = l.split(":", 1)[1].strip()
            break
except OSError:
    pass
doc = {"machine": {"cpu": cpu, "cores": os.cpu_count(),
                   "system": platform.platform()}, "results": rows}
with open(sys.argv[2], "w") as f:
    json.dump(doc, f, indent=1)
print("pm bench on %s (%d cores)" % (cpu, os.cpu_count()))
print("%-52s %14s %14s %8s" % ("measure", "pm", "reference", "ratio"))
def row(name, a, b, unit=""):
    r = a / b if b else float("nan")
    print("%-52s %14s %14s %8.2f" % (name, ("%.4g" % a) + unit,
                                     ("%.4g" % b) + unit, r))
for r in rows:
    w = r["what"]
    if w == "knn":
        n = "%.3gM" % (r["photons"] / 1e6)
        if r["k"] == 50:
            row("kd-tree build, %s photons, 1 thread (FLANN)" % n,
                r["pm_build_s"], r["flann_build_s"], " s")
            if r.get("flann_build_file_order_s", -1) > 0:
                row("  the same, FLANN on the file's order" ,
                    r["pm_build_s"], r["flann_build_file_order_s"], " s")
            print("%-52s %14s %14s %8s" % (
                "kd-tree build, %s photons, %d threads" % (n, r["threads"]),
                "%.4g s" % r["pm_build_all_cores_s"], "-", "-"))
            if "pm_build_best_s" in r:
                row("kd-tree build speed-up, %s, 1 -> %d threads" % (
                    n, r["threads"]), r["pm_build_best_s"],
                    r["pm_build_all_cores_best_s"], " s")
        row("k=%d queries/s, %s photons (FLANN)" % (r["k"], n),
            r["pm_qps"], r["flann_qps"])
        if "pm_qps_single" in r:
            row("k=%d, one query a call, %s photons (FLANN)" % (r["k"], n),
                r["pm_qps_single"], r["flann_qps"])
        if r["mismatches"]:
            print("  warning: %d queries disagree with FLANN" % r["mismatches"])
    elif w == "range":
        print("%-52s %14.4g %14s %8s" % (
            "radius queries/s, %.3gM, %.0f found (k=%d)" % (
                r["photons"] / 1e6, r["found_per_query"], r["k"]),
            r["range_qps"], "-", "-"))
    elif w == "shoot-vs-rays":
        ppath = r["photons_per_path"]
        row("%s: stored photons/s/core (Embree rays/s)" % r["scene"],
            r["paths_per_s"] * ppath, r["rays"]["rays_per_s"])
        print("%-52s %14.4g %14s %8s" % ("%s: photon paths/s/core" % r["scene"],
                                         r["paths_per_s"], "-", "-"))
        c = r.get("casts")
        if c:
            row("  its own rays cast alone, rays/s (Embree rays/s)",
                c["rays"] / c["casts_s"], r["rays"]["rays_per_s"])
            row("  the casts' time over tracing's (in memory)",
                c["casts_s"], c["shoot_s"], " s")
            # The row above it but for the map's file: what the
            # pass makes without the box, checksum and write of
            # pm-shoot's output (44 MB a million Cornell box paths).
            row("  stored photons/s, the pass in memory",
                c["stored"] / c["shoot_s"], r["rays"]["rays_per_s"])
            row("  stored photons/s if pm's own work took no time",
                c["stored"] / c["casts_s"], r["rays"]["rays_per_s"])
    elif w == "speedup":
        row("%s speed-up, 1 -> %d threads%s" % (
            r["tool"], r["threads"],
            ", " + r["work"] if "work" in r else ""),
            r["one_s"] / r["all_s"], r["threads"], "x")
        if "one_stage_s" in r:
            row("  the render stage alone (-v), %.3g -> %.3g s" % (
                r["one_stage_s"], r["all_stage_s"]),
                r["one_stage_s"] / r["all_stage_s"], r["threads"], "x")
    elif w == "crc":
        print("%-52s %14s %14s %8s" % ("CRC-32 GB/s, %s, %s" % (
            ("zlib", "PCLMULQDQ", "VPCLMULQDQ")[r["path"]],
            "in cache" if r["bytes"] < 1 << 20 else "from memory"),
            "%.4g" % r["gb_per_s"], "-", "-"))
    elif w == "rss":
        row("%s peak memory / map, MB" % r["tool"],
            r["max_rss_kib"] * 1024 / 1e6, r["map_bytes"] / 1e6)
    elif w == "bytes":
        print("%-52s %14d %14s %8s" % ("bytes per photon in memory",
                                        r["photon_bytes_in_memory"], "-", "-"))
        print("%-52s %14.2f %14s %8s" % ("bytes per photon on disk",
                                          r["disk_bytes"] / r["photons"], "-", "-"))
        print("%-52s %14.2f %14s %8s" % ("bytes per photon on disk, zlib",
                                          r["compressed_bytes"] / r["photons"], "-", "-"))
    elif w == "paths":
        if r["mitsuba_samples_per_s"] is None:
            print("%-52s %14.4g %14s %8s" % (
                "%s: camera paths/s/core (no Mitsuba)" % r["scene"],
                r["pm_samples_per_s"], "-", "-"))
        else:
            row("%s: camera paths/s/core (Mitsuba)" % r["scene"],
                r["pm_samples_per_s"], r["mitsuba_samples_per_s"])
    elif w == "shoot-big":
        print("%-52s %14.4g %14s %8s" % ("shot %d photons, all cores, s" % r["photons"],
                                          r["seconds"], "-", "-"))
print("JSON: %s" % sys.argv[2])
PY
