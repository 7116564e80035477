#!/usr/bin/env python3
"""study.py: what accuracy costs in time, for pm and for Mitsuba 3.

    study.py [--scenes a,b,c] [--quick] [--out out/accuracy]

Run from the repository root by `make accuracy` (pipelines/accuracy.mk),
after tests/accuracy/references.sh has made the references.  For each scene
it sweeps the knobs that trade time for accuracy, one at a time from a base
setting (photons in the global and caustic maps, lookupSize, the radii,
final gathering samples, samples per pixel, progressive passes), runs pm's
pipeline (pm-shoot, pm-balance, pm-render, pm-downsample) timing each stage
by the wall clock, and renders the scene with Mitsuba 3's path tracer at a
range of sample counts, the peer at the same budgets on the same cores.

Error is measured against the reference, the mean of two Mitsuba halves A
and B: relMSE = mean over pixels and channels of (x - ref)^2 / (ref^2 +
0.01).  The reference's own noise adds mean(((A - B) / 2)^2 / (ref^2 +
0.01)) to that in expectation; it is printed as the floor and subtracted
(`relmse` is the corrected value, `relmse_raw` the measured one).  FLIP
(the flip-evaluator package, HDR mode) is added when it imports.

Each run's result is kept in OUT/runs/KEY.json, KEY naming the run's
settings and the binaries' and scene's hashes, so an interrupted study
resumes and a finished one re-plots for free; OUT/results.tsv holds them
all.  Times are those of the run that made the file.
"""

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
BIN = os.path.join(ROOT, "bin")
RES = 128

# The documented pipeline (README, pm-render(1)): pm-shoot, pm-balance and
# pm-render with their defaults, only the samples per pixel chosen, given
# to both pm-shoot and pm-render as the scene's $spp (-D spp=N), as a user
# sets a scene's sample_count; this is the line the headline compares with
# Mitsuba.  The other sweeps move one knob at a time from it (at 16 spp)
# to show what each costs and buys.  A config: photon paths per map (0:
# pm-shoot's default, one path per ten camera samples of the scene's film
# and sampler, pm-shoot(1)), spp, and extra pm-render and pm-balance
# arguments.  The caustic map is shot only where a scene has specular
# surfaces (pm-shoot decides).
BASE = {"global": 0, "caustic": 0, "spp": 16, "render": [], "balance": []}
RECOMMENDED_SPP = [1, 2, 4, 16, 64, 256, 1024]
SWEEPS = [
    # (name, method, [(label, overrides)]): photon counts show the bias
    # of the records and caustics falling with photons; at 16 spp the
    # default is 26k paths per map.
    ("photons", "pm", [("photons=%dk" % (v // 1000),
                        {"global": v, "caustic": v})
                       for v in (10000, 100000, 400000, 1600000)]),
    # At 16 spp the default cache is every 2nd pixel with 64 rays.
    ("cache", "pm", [("cache-step 1", {"render": ["--cache-step", "1"]}),
                     ("cache-step 4", {"render": ["--cache-step", "4"]}),
                     ("cache-step 4, 256 rays (0.3.0's grid)",
                      {"render": ["--cache-step", "4", "--cache-rays",
                                  "256"]}),
                     ("cache-rays 16", {"render": ["--cache-rays", "16"]}),
                     ("cache-rays 256", {"render": ["--cache-rays",
                                                    "256"]}),
                     ("cache-accuracy 0.3 (0.3.0's)", {"render": [
                         "--cache-accuracy", "0.3"]}),
                     ("cache-accuracy 1.0", {"render": [
                         "--cache-accuracy", "1.0"]})]),
    ("no-cache", "pm", [("gather per sample, 4 rays",
                         {"render": ["--cache-step", "0"]})]),
    ("direct", "pm", [("direct-samples 4", {"render": ["--direct-samples",
                                                       "4"], "spp": 4})]),
    # Version 1's default: the global map's photons shown directly at
    # camera hits (the blotches this version removes), for comparison.
    ("global-map", "pm-global-map", [
        ("spp=%d" % v, {"spp": v, "render": ["--no-final-gather",
                                              "--lookup-size", "120"],
                        "balance": ["--irradiance-stride", "0"]})
        for v in (4, 16, 64)]),
]
# Scenes with media (data/spot-haze.xml): the irradiance cache is off
# there (every camera sample gathers, docs/media.md), so its sweeps and the
# global-map sweep say nothing; the volume estimate is swept instead, and
# every pm run also records what the volume map costs (its photons, its
# bytes on disk and in memory, pm-render's peak memory).
MEDIA_SCENES = {"spot-haze"}
MEDIA_SWEEPS = {"photons", "direct"}
VOLUME_SWEEP = ("volume", "pm", [
    ("volume-estimate beam", {"render": ["--volume-estimate", "beam"]})])
PROG_PASSES = 16
PROG = {"global": 100000, "caustic": 100000, "spp": 4,
        "render": [], "balance": []}
MI_SPP = [4, 8, 16, 32, 64, 128, 256, 1024, 2048]
QUICK_MI_SPP = [4, 16]


def sh(cmd):
    """Runs cmd (a list), returns its wall time; raises on failure."""
    t0 = time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd), r.returncode,
                                                r.stderr.decode()[-2000:]))
    return dt


def sh_rss(cmd):
    """Runs cmd (a list); returns (wall time, peak resident memory of that
    process in KiB, or None).  The peak comes from GNU time (-f %M): the
    kernel's own (wait4's ru_maxrss) keeps, across exec, the high-water
    mark of the forked Python that holds Mitsuba (~110 MiB), so it would
    report that instead of pm-render's."""
    gtime = "/usr/bin/time"
    have = os.access(gtime, os.X_OK)
    fd, rss = tempfile.mkstemp(prefix="study-rss-")
    os.close(fd)
    t0 = time.perf_counter()
    r = subprocess.run(([gtime, "-f", "%M", "-o", rss] if have else []) +
                       cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    dt = time.perf_counter() - t0
    kb = None
    try:
        with open(rss) as f:
            kb = int(f.read().split()[-1])
    except (OSError, ValueError, IndexError):
        kb = None
    os.remove(rss)
    if r.returncode != 0:
        raise RuntimeError("%s: exit %d: %s" % (" ".join(cmd), r.returncode,
                                                r.stderr.decode()[-2000:]))
    return dt, kb


def file_hash(paths):
    h = hashlib.sha256()
    for p in paths:
        with open(p, "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:12]


class Images:
    """Reads EXR with Mitsuba's Bitmap; measures error against one
    reference."""

    def __init__(self, variant):
        import mitsuba as mi
        mi.set_variant(variant)
        self.mi = mi
        try:
            import flip_evaluator
            self.flip = flip_evaluator
        except ImportError:
            self.flip = None

    def read(self, path):
        a = np.array(self.mi.Bitmap(path), dtype=np.float64)
        return a[:, :, :3]

    def set_reference(self, a_path, b_path):
        a, b = self.read(a_path), self.read(b_path)
        self.ref = 0.5 * (a + b)
        self.den = self.ref ** 2 + 0.01
        self.floor = float(np.mean(0.25 * (a - b) ** 2 / self.den))
        self.ref_mean = self.ref.mean(axis=(0, 1))

    def error(self, path):
        x = self.read(path)
        raw = float(np.mean((x - self.ref) ** 2 / self.den))
        out = {"relmse_raw": raw, "relmse": max(raw - self.floor, 1e-12),
               "mean_err": float(np.max(np.abs(
                   x.mean(axis=(0, 1)) / self.ref_mean - 1.0)))}
        if self.flip is not None:
            try:
                _, m, _ = self.flip.evaluate(
                    self.ref.astype(np.float32), x.astype(np.float32), "HDR")
                out["flip"] = float(m)
            except Exception as e:  # a FLIP failure must not stop the study
                out["flip_error"] = str(e)[:200]
        return out


class Study:
    def __init__(self, args):
        self.out = args.out
        self.tmp = os.path.join(self.out, "tmp")
        self.runs = os.path.join(self.out, "runs")
        os.makedirs(self.tmp, exist_ok=True)
        os.makedirs(self.runs, exist_ok=True)
        venv = os.environ.get("PM_VENV", os.path.join(ROOT, "build", "venv"))
        with open(os.path.join(venv, "pm-variant")) as f:
            self.variant = f.read().strip()
        self.img = Images(self.variant)
        self.bins = file_hash([os.path.join(BIN, t) for t in (
            "pm-shoot", "pm-balance", "pm-render", "pm-downsample")])
        self.results = []
        self.quick = args.quick
        self.mi_seed = args.mitsuba_seed
        self.skip = set(x for x in args.skip.split(",") if x)

    def cached(self, key):
        p = os.path.join(self.runs, key + ".json")
        if os.path.isfile(p):
            with open(p) as f:
                return json.load(f)
        return None

    def keep(self, key, rec):
        p = os.path.join(self.runs, key + ".json")
        with open(p + ".tmp", "w") as f:
            json.dump(rec, f, indent=1)
        os.replace(p + ".tmp", p)
        self.results.append(rec)
        print("%-12s %-14s %-22s %7.2f s  relMSE %.3g%s" % (
            rec["scene"], rec["sweep"], rec["label"], rec["total_s"],
            rec["relmse"], "  FLIP %.4f" % rec["flip"] if "flip" in rec
            else ""), flush=True)

    def pm_map(self, scene, seed, nglobal, ncaustic, tag, balance=(),
               spp=None):
        """Shoots and balances one map; returns (path, shoot s, balance s)."""
        shot = os.path.join(self.tmp, tag + "-shot.pmap")
        bal = os.path.join(self.tmp, tag + ".pmap")
        counts = []
        if nglobal:
            counts += ["--photons", str(nglobal)]
        if ncaustic:
            counts += ["--caustic-photons", str(ncaustic)]
        t_shoot = sh([os.path.join(BIN, "pm-shoot"), "-q", "-f", "--seed",
                      str(seed)] + counts + ["-D", "res=%d" % RES] +
                     (["-D", "spp=%d" % spp] if spp else []) +
                     ["-o", shot, scene])
        t_bal = sh([os.path.join(BIN, "pm-balance"), "-q", "-f"] +
                   list(balance) + ["-o", bal, shot])
        os.remove(shot)
        return bal, t_shoot, t_bal

    def pm_render(self, scene, pmap, c, out, seed=0, extra=()):
        cmd = [os.path.join(BIN, "pm-render"), "-q", "-f", "--seed", str(seed),
               "--spp", str(c["spp"]), "--size", "%dx%d" % (RES, RES),
               "-D", "res=%d" % RES, "-D", "spp=%d" % c["spp"]] + \
            list(c["render"])
        cmd += list(extra) + ["-o", out, scene, pmap]
        t, self.last_rss = sh_rss(cmd)
        return t

    def map_stats(self, pmap):
        """What a balanced map holds: its bytes on disk, photons in all,
        and the volume map's photons and bytes in memory (pm-inspect)."""
        r = subprocess.run([os.path.join(BIN, "pm-inspect"), pmap],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        kv = {}
        for line in r.stdout.decode().splitlines():
            f = line.split("\t")
            if len(f) >= 2:
                kv[f[0]] = f[1]
        per = float(kv.get("bytes_per_photon_in_memory", "0"))
        vol = int(kv.get("volume.photons", "0"))
        return {"map_bytes": os.path.getsize(pmap),
                "photons": int(kv.get("photons", "0")),
                "volume_photons": vol,
                "volume_bytes": int(vol * per)}

    def run_pm(self, name, scene, shash, sweep, label, c, method):
        key = "%s-%s" % (name, hashlib.sha256(json.dumps(
            [shash, self.bins, RES, c, method], sort_keys=True).encode())
            .hexdigest()[:16])
        rec = self.cached(key)
        if rec is not None:
            # A sweep may meet the base setting again: one row for both.
            if rec not in self.results:
                self.results.append(rec)
            return
        tag = name
        pmap, t_shoot, t_bal = self.pm_map(scene, 1, c["global"],
                                           c["caustic"], tag, c["balance"],
                                           spp=c["spp"])
        raw = os.path.join(self.tmp, tag + "-raw.exr")
        final = os.path.join(self.tmp, tag + ".exr")
        t_render = self.pm_render(scene, pmap, c, raw)
        t_down = sh([os.path.join(BIN, "pm-downsample"), "-q", "-f", "-o", final,
                     raw])
        stats = self.map_stats(pmap)
        os.remove(pmap)
        rec = {"scene": name, "method": method, "sweep": sweep,
               "label": label, "config": c, "shoot_s": t_shoot,
               "balance_s": t_bal, "render_s": t_render,
               "downsample_s": t_down,
               "total_s": t_shoot + t_bal + t_render + t_down,
               "render_maxrss_kb": self.last_rss,
               "floor": self.img.floor}
        rec.update(stats)
        rec.update(self.img.error(final))
        self.keep(key, rec)

    def run_progressive(self, name, scene, shash):
        c = dict(BASE)
        c.update(PROG)
        passes = 4 if self.quick else PROG_PASSES
        key = "%s-prog-%s" % (name, hashlib.sha256(json.dumps(
            [shash, self.bins, RES, c, passes], sort_keys=True).encode())
            .hexdigest()[:16])
        prev = self.cached(key)
        if prev is not None:
            self.results.extend(prev["passes"])
            return
        done = []
        t_total = 0.0
        stages = {"shoot_s": 0.0, "balance_s": 0.0, "render_s": 0.0,
                  "downsample_s": 0.0}
        for i in range(1, passes + 1):
            tag = "%s-pass%03d" % (name, i)
            pmap, t_shoot, t_bal = self.pm_map(
                scene, i, c["global"], c["caustic"], tag,
                list(c["balance"]) + ["--pass", str(i)])
            raw = os.path.join(self.tmp, tag + ".exr")
            t_render = self.pm_render(scene, pmap, c, raw, seed=i,
                                      extra=("--pass", str(i)))
            os.remove(pmap)
            done.append(raw)
            mean = os.path.join(self.tmp, name + "-mean.exr")
            t_down = sh([os.path.join(BIN, "pm-downsample"), "-q", "-f", "-o",
                         mean] + done)
            stages["shoot_s"] += t_shoot
            stages["balance_s"] += t_bal
            stages["render_s"] += t_render
            stages["downsample_s"] += t_down
            t_total += t_shoot + t_bal + t_render + t_down
            rec = {"scene": name, "method": "pm-progressive",
                   "sweep": "passes", "label": "passes=%d" % i,
                   "config": dict(c, passes=i), "total_s": t_total,
                   "floor": self.img.floor}
            rec.update(stages)
            rec.update(self.img.error(mean))
            print("%-12s %-14s %-22s %7.2f s  relMSE %.3g" % (
                name, "passes", rec["label"], t_total, rec["relmse"]),
                flush=True)
            self.results.append(rec)
        for p in done:
            os.remove(p)
        rec_all = {"passes": [r for r in self.results
                              if r["scene"] == name
                              and r["method"] == "pm-progressive"]}
        with open(os.path.join(self.runs, key + ".json"), "w") as f:
            json.dump(rec_all, f, indent=1)

    def run_mitsuba(self, name, scene):
        for spp in (QUICK_MI_SPP if self.quick else MI_SPP):
            out = os.path.join(self.tmp, "%s-mi-%d.exr" % (name, spp))
            meta_path = out + ".json"
            py = os.path.join(os.path.dirname(sys.executable), "python")
            r = subprocess.run([py, os.path.join(
                ROOT, "tests", "mitsuba", "render_mitsuba.py"), scene, out,
                "--spp", str(spp), "-D", "res=%d" % RES,
                "--seed", str(self.mi_seed),
                "--variant", self.variant, "--key-scope", "scene",
                "--meta", meta_path],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            if r.returncode != 0:
                print("study: %s: Mitsuba failed: %s" % (
                    name, r.stderr.decode()[-500:]), file=sys.stderr)
                return
            with open(meta_path) as f:
                meta = json.load(f)
            rec = {"scene": name, "method": "mitsuba-path", "sweep": "spp",
                   "label": "spp=%d" % spp, "config": {"spp": spp},
                   "render_s": meta["seconds"],
                   "load_s": meta.get("load_seconds", 0.0),
                   "total_s": meta["seconds"] + meta.get("load_seconds", 0.0),
                   "floor": self.img.floor, "variant": meta["variant"]}
            rec.update(self.img.error(out))
            self.keep("%s-mi-%d-%s" % (name, spp, meta["key"]), rec)

    def scene(self, name):
        scene = os.path.join(ROOT, "data", name + ".xml")
        ref = os.path.join(self.out, "ref", name)
        if not os.path.isfile(ref + "-a.exr"):
            print("study: %s: no reference (run tests/accuracy/"
                  "references.sh); skipped" % name, file=sys.stderr)
            return
        self.img.set_reference(ref + "-a.exr", ref + "-b.exr")
        print("study: %s: reference noise floor relMSE %.2g" % (
            name, self.img.floor), flush=True)
        shash = file_hash([scene])
        for spp in ([4, 16] if self.quick else RECOMMENDED_SPP):
            c = dict(BASE, spp=spp)
            self.run_pm(name, scene, shash, "recommended", "spp=%d" % spp, c,
                        "pm-recommended")
        media = name in MEDIA_SCENES
        sweeps = [w for w in SWEEPS if w[0] in MEDIA_SWEEPS] + \
            [VOLUME_SWEEP] if media else SWEEPS
        for sweep, method, runs in sweeps:
            if self.quick or sweep in self.skip:
                continue
            for label, over in runs:
                c = dict(BASE)
                c.update(over)
                self.run_pm(name, scene, shash, sweep, label, c, method)
        self.run_progressive(name, scene, shash)
        self.run_mitsuba(name, scene)

    def write_tsv(self):
        cols = ["scene", "method", "sweep", "label", "total_s", "shoot_s",
                "balance_s", "render_s", "downsample_s", "relmse",
                "relmse_raw", "floor", "mean_err", "flip"]
        path = os.path.join(self.out, "results.tsv")
        with open(path + ".tmp", "w") as f:
            f.write("\t".join(cols) + "\n")
            for r in self.results:
                f.write("\t".join(
                    ("%.6g" % r[c]) if isinstance(r.get(c), float)
                    else str(r.get(c, "")) for c in cols) + "\n")
        os.replace(path + ".tmp", path)
        with open(os.path.join(self.out, "results.json"), "w") as f:
            json.dump(self.results, f, indent=1)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes",
                   default="cornell-box,caustics,bunny-glass,bunny,"
                   "spot-haze")
    p.add_argument("--skip", default="",
                   help="sweeps to leave out, comma-separated")
    p.add_argument("--out", default=os.path.join(ROOT, "out", "accuracy"))
    p.add_argument("--mitsuba-seed", type=int, default=7,
                   help="seed of Mitsuba's runs; another one renders them "
                   "afresh instead of taking them from the cache")
    p.add_argument("--quick", action="store_true",
                   help="a few runs per scene, to check the machinery")
    args = p.parse_args(argv)
    st = Study(args)
    t0 = time.time()
    for name in args.scenes.split(","):
        st.scene(name)
        st.write_tsv()
    shutil.rmtree(st.tmp, ignore_errors=True)
    print("study: %d runs, %.0f s, results in %s" % (
        len(st.results), time.time() - t0,
        os.path.join(args.out, "results.tsv")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
