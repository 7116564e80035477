#!/usr/bin/env python3
"""compare.py: decide whether two Monte Carlo renders of one scene agree.

    compare.py A.exr B.exr [--a2 A2.exr] [--b2 B2.exr] [--mean-tol 0.01]
               [--block 16] [--z 4] [--max-outliers 0.01] [--diff D.exr]

A is the reference (Mitsuba), B the candidate (pm-render). Both are noisy, so
"equal" means "differ by no more than their noise says they may". Checks,
one summary line each:

  size    same width, height and channels;
  finite  no NaN or infinity in either image;
  mean    per-channel image means within --mean-tol (relative) of each other:
          a wrong light power, BSDF albedo or path-depth rule shows here;
  relMSE  mean of (B-A)^2 / (A^2 + 0.01), printed next to what the noise
          alone predicts (information only, it never fails);
  blocks  the image cut into BLOCKxBLOCK blocks; for each block and channel
          z = (mean_B - mean_A) / sqrt(var_A + var_B); more than
          --max-outliers of them with |z| > --z fails. This catches local
          errors (a missing shadow, a flipped image, a wrong wall colour)
          that the global means average away.

The variance of a block mean comes from a second render of each side with
another seed (--a2, --b2) when given: half the squared difference of two
independent renders estimates each pixel's variance without bias, and the
block-level differences of the same pair measure how much neighbouring
pixels' errors are correlated (photon maps share photons between pixels), a
factor (at least 1) by which the per-pixel estimate is inflated. Without a second render
a side's pixel variance is estimated from differences between neighbouring
pixels, which also counts real image gradients and so errs on the side of a
larger variance (fewer false alarms, less power).

Exit status 0 when every check passes, 1 otherwise.
"""

import argparse
import sys

import numpy as np

EPS_RELMSE = 1e-2


def load(path):
    """An EXR (or any format Mitsuba reads) as an HxWx3 float64 array."""
    import mitsuba as mi
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    try:
        bmp = mi.Bitmap(path)
    except Exception as e:  # Mitsuba raises RuntimeError with the reason
        raise SystemExit("compare: cannot read %s: %s" % (path, e))
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32,
                      srgb_gamma=False)
    arr = np.array(bmp, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return arr


def write_exr(path, arr):
    import mitsuba as mi
    bmp = mi.Bitmap(np.ascontiguousarray(arr, dtype=np.float32),
                    pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.write(path)


def block_sums(img, b):
    """Sum over each bxb block (the image cropped to whole blocks)."""
    h, w, c = img.shape
    hb, wb = h // b, w // b
    x = img[:hb * b, :wb * b]
    return x.reshape(hb, b, wb, b, c).sum(axis=(1, 3))


def side_stats(x1, x2, b):
    """Mean image, per-block variance of its block means, correlation
    factor, per-pixel variance of the mean image, and how it was found."""
    n = b * b
    if x2 is not None:
        mean = 0.5 * (x1 + x2)
        d = x1 - x2
        # Var of one render's pixel is E[d^2]/2; of the mean of two, E[d^2]/4.
        pix_var = 0.25 * d * d
        # Block means of d: their spread versus the per-pixel prediction
        # says how correlated neighbouring pixels' errors are. The ratio is
        # taken block by block and then averaged: a ratio of sums over the
        # whole image is ruled by the few blocks that hold fireflies, and
        # swings by a factor of two between seeds for a path tracer whose
        # pixels are independent.
        bd = block_sums(d, b) / n
        pred = block_sums(d * d, b) / (n * n)
        live = pred > 0
        corr = float((bd[live] ** 2 / pred[live]).mean()) if live.any() \
            else 1.0
        corr = max(corr, 1.0)
        block_var = corr * block_sums(pix_var, b) / (n * n)
        return mean, block_var, corr, pix_var, "second render"
    # One render: half the mean squared neighbour difference, horizontally
    # and vertically, upper-bounds the pixel variance where the image is
    # smooth (its gradient adds, never subtracts).
    dx = np.zeros_like(x1)
    dy = np.zeros_like(x1)
    dx[:, :-1] = x1[:, 1:] - x1[:, :-1]
    dx[:, -1] = dx[:, -2] if x1.shape[1] > 1 else 0
    dy[:-1] = x1[1:] - x1[:-1]
    dy[-1] = dy[-2] if x1.shape[0] > 1 else 0
    pix_var = 0.25 * (dx * dx + dy * dy)
    block_var = block_sums(pix_var, b) / (n * n)
    return x1, block_var, 1.0, pix_var, "neighbour differences"


def main(argv):
    p = argparse.ArgumentParser(
        description="Compare two noisy renders of one scene.")
    p.add_argument("a", help="reference image (Mitsuba)")
    p.add_argument("b", help="candidate image (pm-render)")
    p.add_argument("--a2", help="second reference render, another seed")
    p.add_argument("--b2", help="second candidate render, another seed")
    p.add_argument("--mean-tol", type=float, default=0.01,
                   help="relative tolerance on each channel's mean")
    p.add_argument("--block", type=int, default=16)
    p.add_argument("--z", type=float, default=4.0,
                   help="|z| above which a block is an outlier")
    p.add_argument("--max-outliers", type=float, default=0.01,
                   help="largest fraction of outlier blocks that passes")
    p.add_argument("--diff", help="write B - A to this EXR")
    p.add_argument("--name", default="",
                   help="prefix for the summary lines")
    args = p.parse_args(argv)
    tag = "compare%s:" % (" " + args.name if args.name else "")
    failed = []

    def report(check, ok, text):
        status = "ok  " if ok is True else ("info" if ok is None else "FAIL")
        print("%s %-6s %s %s" % (tag, check, status, text))
        if ok is False:
            failed.append(check)

    a1 = load(args.a)
    b1 = load(args.b)
    a2 = load(args.a2) if args.a2 else None
    b2 = load(args.b2) if args.b2 else None

    shapes = {"A": a1.shape, "B": b1.shape}
    if a2 is not None:
        shapes["A2"] = a2.shape
    if b2 is not None:
        shapes["B2"] = b2.shape
    same = len(set(shapes.values())) == 1
    h, w, c = a1.shape
    report("size", same, "%dx%d, %d channels" % (w, h, c) if same else
           "differ: " + ", ".join("%s %dx%dx%d" % (k, s[1], s[0], s[2])
                                  for k, s in shapes.items()))
    if not same:
        print("%s FAIL (%s)" % (tag, ", ".join(failed)))
        return 1

    bad = {k: int((~np.isfinite(v)).sum()) for k, v in
           (("A", a1), ("B", b1), ("A2", a2), ("B2", b2)) if v is not None}
    nbad = sum(bad.values())
    report("finite", nbad == 0, "all pixels finite" if nbad == 0 else
           "non-finite pixels: " + ", ".join("%s %d" % kv for kv in
                                             bad.items() if kv[1]))
    if nbad:
        print("%s FAIL (%s)" % (tag, ", ".join(failed)))
        return 1

    b = max(1, min(args.block, h, w))
    ma, va, corr_a, pva, how_a = side_stats(a1, a2, b)
    mb, vb, corr_b, pvb, how_b = side_stats(b1, b2, b)
    chan = "RGB" if c == 3 else "".join(str(i) for i in range(c))

    # Means, with the standard error of their difference for scale.
    mean_a = ma.mean(axis=(0, 1))
    mean_b = mb.mean(axis=(0, 1))
    npix = h * w
    se = np.sqrt((va.sum(axis=(0, 1)) + vb.sum(axis=(0, 1)))
                 * (b * b) ** 2 / npix ** 2)
    parts = []
    ok = True
    for i in range(c):
        ref = mean_a[i]
        rel = (mean_b[i] - ref) / ref if ref > 0 else \
            (0.0 if mean_b[i] == ref else float("inf"))
        if not abs(rel) <= args.mean_tol:
            ok = False
        parts.append("%s %.5g/%.5g (%+.2f%%, %.1f sigma)"
                     % (chan[i], ref, mean_b[i], 100 * rel,
                        (mean_b[i] - ref) / se[i] if se[i] > 0 else 0.0))
    report("mean", ok, "A/B " + "  ".join(parts)
           + "  (tol %.2f%%)" % (100 * args.mean_tol))

    # relMSE against the value the two noise levels alone would give.
    denom = ma * ma + EPS_RELMSE
    relmse = float(((mb - ma) ** 2 / denom).mean())
    expect = float(((pva + pvb) / denom).mean())
    if a2 is not None and b2 is not None:
        report("relMSE", None, "%.5g (noise alone predicts %.5g, ratio %.2f)"
               % (relmse, expect, relmse / expect if expect > 0 else
                  float("inf")))
    else:
        report("relMSE", None, "%.5g (no second renders, so no noise "
               "prediction)" % relmse)

    # Blocks.
    n = b * b
    da = block_sums(ma, b) / n
    db = block_sums(mb, b) / n
    # A floor of 1e-5 relative keeps noiseless blocks (a constant sky)
    # from turning float rounding of the same constant (Mitsuba stores
    # 0.8 as 0.8000019) into an infinite z.
    var = va + vb + (1e-5 * 0.5 * (np.abs(da) + np.abs(db))) ** 2
    diff = db - da
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(var > 0, diff / np.sqrt(var),
                     np.where(diff == 0, 0.0, np.inf))
    az = np.abs(z)
    nblk = az.size
    nout = int((az > args.z).sum())
    frac = nout / nblk
    worst = np.unravel_index(int(np.argmax(az)), az.shape)
    finite_z = z[np.isfinite(z)]
    chi = float((finite_z ** 2).mean()) if finite_z.size else float("nan")
    report("blocks", frac <= args.max_outliers,
           "%d/%d %dx%d block-channels with |z|>%g (%.2f%%, limit %.2f%%); "
           "max |z| %.3g at block x=%d y=%d %s; mean z^2 %.2f; "
           "variance from %s (A, corr %.2f) and %s (B, corr %.2f)"
           % (nout, nblk, b, b, args.z, 100 * frac, 100 * args.max_outliers,
              az[worst], worst[1], worst[0], chan[worst[2]], chi,
              how_a, corr_a, how_b, corr_b))

    if args.diff:
        write_exr(args.diff, (mb - ma).astype(np.float32))

    if failed:
        print("%s FAIL (%s)" % (tag, ", ".join(failed)))
        return 1
    print("%s PASS" % tag)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
