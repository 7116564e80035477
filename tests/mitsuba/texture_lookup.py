#!/usr/bin/env python3
"""texture_lookup.py: pm's bitmap lookups against Mitsuba 3's.

    texture_lookup.py TEXLOOKUP DIR

Writes into DIR a 7x5 OpenEXR of random linear values and the 8x6 PNG of
write_png.py, then looks both up at 2000 points of uv in [-2.5, 3.5]^2 (so
that every wrap mode matters) with every filter_type, wrap_mode and raw,
in Mitsuba (scalar_rgb) and through TEXLOOKUP (pm). They must agree to
float rounding for OpenEXR (1e-5), and for PNG to the half-float storage
Mitsuba keeps 8-bit images in (relative 2^-11, so 1e-3 of the value, plus
1e-6). Prints one line per case; exit status 1 if any disagrees.
"""
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    tool, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(3)
    exr = os.path.join(out, "lookup.exr")
    png = os.path.join(out, "lookup.png")
    mi.Bitmap(rng.random((5, 7, 3)).astype(np.float32)).write(exr)
    subprocess.run([sys.executable, os.path.join(HERE, "write_png.py"), png],
                   check=True)
    uv = rng.uniform(-2.5, 3.5, (2000, 2)).astype(np.float32)
    text = "\n".join("%r %r" % (float(a), float(b)) for a, b in uv) + "\n"
    failed = 0
    for path, raws in ((exr, (True,)), (png, (False, True))):
        for raw in raws:
            for filt in ("bilinear", "nearest"):
                for wrap in ("repeat", "mirror", "clamp"):
                    tex = mi.load_dict({"type": "bitmap", "filename": path,
                                        "filter_type": filt,
                                        "wrap_mode": wrap, "raw": raw})
                    si = mi.SurfaceInteraction3f()
                    ref = []
                    for a, b in uv:
                        si.uv = [float(a), float(b)]
                        ref.append(list(tex.eval(si)))
                    ref = np.array(ref)
                    res = subprocess.run(
                        [tool, path, filt, wrap, "raw" if raw else "srgb"],
                        input=text, capture_output=True, text=True)
                    if res.returncode != 0:
                        print("texture_lookup: %s: %s" % (tool, res.stderr))
                        return 1
                    got = np.array([[float(x) for x in line.split()]
                                    for line in res.stdout.split("\n")
                                    if line])
                    tol = (1e-5 if path == exr else
                           1e-3 * np.abs(ref) + 1e-6)
                    diff = np.abs(got - ref)
                    bad = int(np.sum(np.any(diff > tol, axis=1)))
                    failed += bad > 0
                    print("texture_lookup: %s %s %s raw=%s: max |pm - "
                          "Mitsuba| %.2g, %d of %d points beyond tolerance"
                          % (os.path.basename(path), filt, wrap, raw,
                             diff.max(), bad, len(uv)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
