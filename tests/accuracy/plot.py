#!/usr/bin/env python3
"""plot.py: figures and tables of the accuracy study (study.py).

    plot.py [--results out/accuracy/results.json] [--figures docs/accuracy]
            [--summary out/accuracy/summary.md]

Writes, as PNG under --figures: one log-log plot of error against wall time
per scene (every run of every method, and each method's Pareto front),
headline.png (the three scenes side by side, shown in the README), bias.png
(the error of a single photon-map render against photon count) and
progressive.png (the running mean of progressive passes against passes).
--summary gets the tables of docs/accuracy.md in Markdown: every run with
its stage times, the Pareto fronts, and for each scene and method the time
needed to reach relMSE 0.01 and 0.001 with its ratio to Mitsuba 3's path
tracer.
"""

import argparse
import json
import math
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = [
    ("pm-recommended", "pm, documented defaults (spp swept)", "tab:green",
     "s"),
    ("pm", "pm, one knob moved", "tab:blue", "o"),
    ("pm-global-map", "pm, global map shown directly (v1)", "tab:gray", "v"),
    ("pm-progressive", "pm, progressive passes", "tab:orange", "^"),
    ("mitsuba-path", "Mitsuba 3 path tracer (volpath in media)", "tab:red",
     "D"),
]
NAMES = {m[0]: m[1] for m in METHODS}
THRESHOLDS = (0.01, 0.001)


def front(points):
    """The Pareto front of (time, error) pairs: each point faster than every
    point with lower error, sorted by time."""
    out = []
    for t, e, r in sorted(points, key=lambda p: (p[0], p[1])):
        if not out or e < out[-1][1]:
            out.append((t, e, r))
    return out


def time_to(fr, target, extrapolate):
    """Seconds for the front fr to reach error target: log-log interpolation
    between the front points around it; (value, how) with how one of
    'measured', 'extrapolated' (Monte Carlo error ~ 1/time beyond the last
    point, for the unbiased path tracer only) or 'not reached'."""
    for i, (t, e, _) in enumerate(fr):
        if e <= target:
            if i == 0:
                return t, "measured"
            t0, e0 = fr[i - 1][0], fr[i - 1][1]
            f = (math.log(target) - math.log(e0)) / (math.log(e) -
                                                       math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t) -
                                                math.log(t0))), "measured"
    if extrapolate and fr:
        t, e, _ = fr[-1]
        return t * e / target, "extrapolated"
    return None, "not reached"


def fmt_t(v, how):
    if v is None:
        return "not reached"
    s = "%.3g s" % v
    return "~" + s if how == "extrapolated" else s


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--results", default="out/accuracy/results.json")
    p.add_argument("--figures", default="docs/accuracy")
    p.add_argument("--summary", default="out/accuracy/summary.md")
    p.add_argument("--machine", default="")
    args = p.parse_args(argv)
    with open(args.results) as f:
        runs = json.load(f)
    os.makedirs(args.figures, exist_ok=True)
    scenes = []
    for r in runs:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    md = []
    if args.machine:
        md.append("Measured on %s.\n" % args.machine)

    # Per-scene plots, and the headline of all three.
    fig_all, axes = plt.subplots(1, len(scenes), figsize=(5 * len(scenes),
                                                          4.2), squeeze=False)
    fronts = {}
    for si, sc in enumerate(scenes):
        fig, ax = plt.subplots(figsize=(6.4, 4.8))
        for a in (ax, axes[0][si]):
            floor = None
            for key, label, col, mk in METHODS:
                pts = [(r["total_s"], r["relmse"], r) for r in runs
                       if r["scene"] == sc and r["method"] == key]
                if not pts:
                    continue
                floor = pts[0][2]["floor"]
                fr = front(pts)
                fronts[(sc, key)] = fr
                a.scatter([q[0] for q in pts], [q[1] for q in pts], s=14,
                          color=col, marker=mk, alpha=0.45)
                a.plot([q[0] for q in fr], [q[1] for q in fr], color=col,
                       marker=mk, ms=4, lw=1.5, label=label)
            for t in THRESHOLDS:
                a.axhline(t, color="0.6", lw=0.8, ls=":")
            if floor:
                a.axhline(floor, color="k", lw=0.8, ls="--",
                          label="reference noise floor")
            a.set_xscale("log")
            a.set_yscale("log")
            a.set_xlabel("wall time, s (all stages, 2 cores)")
            a.set_ylabel("relMSE against the Mitsuba reference")
            a.set_title(sc)
            a.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(args.figures, sc + ".png"), dpi=110)
        plt.close(fig)
    axes[0][0].legend(fontsize=8)
    fig_all.tight_layout()
    fig_all.savefig(os.path.join(args.figures, "headline.png"), dpi=100)
    plt.close(fig_all)

    # Bias against photons (the 16 spp sweep) and the progressive passes.
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for sc in scenes:
        pts = sorted((r["config"]["global"], r["relmse"], r["mean_err"])
                     for r in runs if r["scene"] == sc and
                     r["sweep"] == "photons")
        if pts:
            ln, = a1.plot([q[0] for q in pts], [q[1] for q in pts],
                          marker="o", label=sc + ", relMSE")
            a1.plot([q[0] for q in pts], [max(q[2], 1e-5) ** 2 for q in pts],
                    marker="x", ls="--", color=ln.get_color(),
                    label=sc + ", (relative error of the mean)^2")
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.set_xlabel("photon paths per map (global and caustic each), 16 spp")
    a1.set_ylabel("error of one photon-map render")
    a1.set_title("bias of one map falls with photons")
    a1.grid(True, which="both", lw=0.3, alpha=0.5)
    a1.legend(fontsize=7)
    for sc in scenes:
        pts = sorted((r["config"]["passes"], r["relmse"]) for r in runs
                     if r["scene"] == sc and r["method"] == "pm-progressive")
        if pts:
            a2.plot([q[0] for q in pts], [q[1] for q in pts], marker=".",
                    label=sc)
            fl = [r["floor"] for r in runs if r["scene"] == sc][0]
            a2.axhline(fl, lw=0.6, ls="--", color=a2.lines[-1].get_color())
    n = [1, 32]
    a2.plot(n, [0.01, 0.01 / 32], color="0.5", lw=0.8, ls=":",
            label="slope -1 (unbiased)")
    a2.set_xscale("log")
    a2.set_yscale("log")
    a2.set_xlabel("passes averaged")
    a2.set_ylabel("relMSE of the running mean")
    a2.set_title("progressive passes converge to the reference")
    a2.grid(True, which="both", lw=0.3, alpha=0.5)
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(args.figures, "bias-progressive.png"), dpi=100)
    plt.close(fig)

    # Tables.
    md.append("### Time to reach a given error\n")
    md.append("| scene | method | relMSE 0.01 | ratio to Mitsuba | "
              "relMSE 0.001 | ratio to Mitsuba |")
    md.append("|---|---|---|---|---|---|")
    for sc in scenes:
        mi = {t: time_to(fronts.get((sc, "mitsuba-path"), []), t, True)
              for t in THRESHOLDS}
        for key, label, _, _ in METHODS:
            fr = fronts.get((sc, key))
            if not fr:
                continue
            cells = []
            for t in THRESHOLDS:
                v, how = time_to(fr, t, key == "mitsuba-path")
                cells.append(fmt_t(v, how))
                if key == "mitsuba-path":
                    cells.append("1")
                elif v is None:
                    best = min(fr, key=lambda q: q[1])
                    cells[-1] = "not reached (best %.2g at %.3g s)" % (
                        best[1], best[0])
                    cells.append("-")
                elif mi[t][0]:
                    cells.append("%.2g" % (v / mi[t][0]))
                else:
                    cells.append("-")
            md.append("| %s | %s | %s |" % (sc, label, " | ".join(cells)))
    md.append("")
    md.append("### Pareto fronts (fastest run for each error)\n")
    md.append("Progressive passes: passes 1, 2, 4, 8, 16 and 32 shown.\n")
    md.append("| scene | method | run | time, s | relMSE |")
    md.append("|---|---|---|---|---|")
    for sc in scenes:
        for key, label, _, _ in METHODS:
            for t, e, r in fronts.get((sc, key), []):
                if key == "pm-progressive" and \
                        r["config"]["passes"] not in (1, 2, 4, 8, 16, 32):
                    continue
                md.append("| %s | %s | %s | %.3g | %.3g |" % (
                    sc, label, r["label"], t, e))
    md.append("")
    md.append("### Every run\n")
    md.append("| scene | method | sweep | run | shoot | balance | render | "
              "downsample | total, s | relMSE | FLIP | mean error |")
    md.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        if r["method"] == "pm-progressive" and \
                r["config"]["passes"] not in (1, 2, 4, 8, 16, 32):
            continue
        g = lambda k: ("%.2f" % r[k]) if k in r else "-"  # noqa: E731
        md.append("| %s | %s | %s | %s | %s | %s | %s | %s | %.2f | %.3g | %s "
                  "| %.2g%% |" % (
                      r["scene"], r["method"], r["sweep"], r["label"],
                      g("shoot_s"), g("balance_s"), g("render_s"),
                      g("downsample_s"), r["total_s"], r["relmse"],
                      "%.3f" % r["flip"] if "flip" in r else "-",
                      100 * r["mean_err"]))
    md.append("")
    # What the volume map costs (scenes with media): pm's documented
    # defaults at each spp, the map's photons and bytes, pm-render's peak
    # memory.
    vol = [r for r in runs if r.get("volume_photons") and
           r["method"] == "pm-recommended"]
    if vol:
        md.append("### What the volume map costs\n")
        md.append("| scene | run | photons in all | volume photons | "
                  "map file, KiB | volume map in memory, KiB | shoot, s | "
                  "balance, s | render, s | pm-render peak memory, MiB |")
        md.append("|---|---|---|---|---|---|---|---|---|---|")
        for r in vol:
            md.append("| %s | %s | %d | %d | %.0f | %.0f | %.2f | %.2f | "
                      "%.2f | %.1f |" % (
                          r["scene"], r["label"], r["photons"],
                          r["volume_photons"], r["map_bytes"] / 1024.0,
                          r["volume_bytes"] / 1024.0, r["shoot_s"],
                          r["balance_s"], r["render_s"],
                          (r.get("render_maxrss_kb") or 0) / 1024.0))
        md.append("")
    floors = {}
    for r in runs:
        floors[r["scene"]] = r["floor"]
    md.append("Reference noise floors (subtracted): " + ", ".join(
        "%s %.2g" % kv for kv in floors.items()) + ".\n")
    os.makedirs(os.path.dirname(args.summary) or ".", exist_ok=True)
    with open(args.summary, "w") as f:
        f.write("\n".join(md) + "\n")
    print("plot: figures in %s, tables in %s" % (args.figures, args.summary))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
