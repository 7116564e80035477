#!/usr/bin/env python3
"""mitsuba_paths.py: Mitsuba 3's camera paths per second on one thread.

    mitsuba_paths.py SCENE.xml RES SPP [VARIANT [REPEATS]]

Renders SCENE at RES x RES with SPP samples per pixel on one thread
(Dr.Jit's thread count 1; run it under taskset to pin the core), once to
warm Dr.Jit's kernel cache and REPEATS times (default 1) timed, and
prints one JSON object: the variant, the samples and the samples per
second of the fastest timed render, with every render's rate in
"runs" (load_file excluded, as pm-render -v excludes loading from its
rate).
The pm side is pm-render --method path -t 1 on the same file; see
tests/bench/bench.sh.
"""

import json
import sys
import time

import drjit as dr
import mitsuba as mi


def main(argv):
    scene, res, spp = argv[1], int(argv[2]), int(argv[3])
    variant = argv[4] if len(argv) > 4 else "llvm_ad_rgb"
    repeats = int(argv[5]) if len(argv) > 5 else 1
    mi.set_variant(variant)
    dr.set_thread_count(1)
    sc = mi.load_file(scene, res=res, spp=spp)
    dr.eval(mi.render(sc, spp=spp, seed=1))
    n = res * res * spp
    runs = []
    for k in range(repeats):
        t0 = time.perf_counter()
        img = mi.render(sc, spp=spp, seed=2 + k)
        dr.eval(img)
        runs.append(n / (time.perf_counter() - t0))
    print(json.dumps({"variant": variant, "samples": n,
                      "samples_per_s": max(runs), "runs": runs}))


if __name__ == "__main__":
    main(sys.argv)
