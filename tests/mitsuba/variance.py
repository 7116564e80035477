#!/usr/bin/env python3
"""variance.py: per-sample variance of pm against Mitsuba on one scene.

    variance.py MI1.exr MI2.exr MI_SPP PM1.exr PM2.exr PM_SPP [--max 2]

Each pair is two renders of the scene with different seeds; half the mean
squared difference of a pair is the variance of a pixel, and times the
samples per pixel the variance of one sample.  Prints both and their
ratio, pm over Mitsuba, and exits 1 when the ratio exceeds --max: pm
needing more than that many times Mitsuba's samples for the same noise.
"""

import argparse
import sys

import numpy as np


def read(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mi1")
    p.add_argument("mi2")
    p.add_argument("mi_spp", type=int)
    p.add_argument("pm1")
    p.add_argument("pm2")
    p.add_argument("pm_spp", type=int)
    p.add_argument("--max", type=float, default=2.0)
    a = p.parse_args()
    v = []
    for f1, f2, spp in ((a.mi1, a.mi2, a.mi_spp), (a.pm1, a.pm2, a.pm_spp)):
        d = read(f1) - read(f2)
        v.append(0.5 * float(np.mean(d * d)) * spp)
    ratio = v[1] / v[0] if v[0] > 0 else float("inf")
    print("variance per sample: Mitsuba %.6g, pm %.6g, ratio %.3f (max %g)"
          % (v[0], v[1], ratio, a.max))
    return 0 if ratio <= a.max else 1


if __name__ == "__main__":
    sys.exit(main())
