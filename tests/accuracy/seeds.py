#!/usr/bin/env python3
"""seeds.py: how far two renders of one scene with different seeds differ.

    seeds.py A.exr B.exr

Prints relMSE / 2 per pixel, mean over pixels and channels of
(a - b)^2 / (m^2 + 0.01) / 2 with m = (a + b) / 2, which is each render's
own error when both are unbiased and independent, raw and after both are
blurred with a Gaussian of sigma 4 pixels: what survives the blur is
low-frequency error, the blotches a photon map can leave.  Used for the
demo (pipelines/bunny.mk, BUNNY_SEED; docs/accuracy.md).  Reads EXR with
Mitsuba's Bitmap from the accuracy venv (build/venv/bin/python).
"""

import sys

import numpy as np


def blur(x, sigma=4.0):
    """A separable Gaussian blur, edges mirrored."""
    r = int(4 * sigma)
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()

    def one(v):
        return np.convolve(np.pad(v, r, mode="reflect"), k, mode="valid")
    return np.apply_along_axis(one, 1, np.apply_along_axis(one, 0, x))


def main(argv):
    if len(argv) != 2:
        sys.exit("usage: seeds.py A.exr B.exr")
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    a, b = (np.array(mi.Bitmap(p), dtype=np.float64)[:, :, :3] for p in argv)
    if a.shape != b.shape:
        sys.exit("seeds.py: the images differ in size")
    den = ((a + b) / 2) ** 2 + 0.01
    raw = float(np.mean((a - b) ** 2 / den)) / 2
    blurred = float(np.mean((blur(a) - blur(b)) ** 2 / den)) / 2
    print("relMSE/2 raw %.3g blurred(sigma 4 px) %.3g" % (raw, blurred))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
