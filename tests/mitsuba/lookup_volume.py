"""lookup_volume.py: pm's grid-volume lookups against Mitsuba's gridvolume.

    python lookup_volume.py VOLGEN WORKDIR

Writes small .vol grids with build/tests/volgen (one and three channels,
odd sizes), draws points inside and around the unit cube, and compares
pm's lookup (volgen lookup) with Mitsuba's Volume.eval at each point, for
every filter_type and wrap_mode.  Exit 0 when all agree to 1e-5 relative.
"""
import os
import subprocess
import sys

import numpy as np
import mitsuba as mi


def main():
    volgen, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(5)
    fails = 0
    for name, res, ch in (("g1", (5, 3, 4), 1), ("g3", (4, 6, 3), 3)):
        path = os.path.join(work, name + ".vol")
        # a grid with distinct values, written in Mitsuba's layout by
        # Mitsuba itself, read by pm
        data = rng.random((res[2], res[1], res[0], ch)).astype(np.float32)
        mi.VolumeGrid(data).write(path)
        pts = rng.uniform(-0.6, 1.6, size=(400, 3))
        for filt in ("trilinear", "nearest"):
            for wrap in ("clamp", "repeat", "mirror"):
                vol = mi.load_dict({"type": "gridvolume", "filename": path,
                                    "filter_type": filt,
                                    "wrap_mode": wrap, "raw": True})
                out = subprocess.run(
                    [volgen, "lookup", path, filt, wrap],
                    input="".join("%.9g %.9g %.9g\n" % tuple(p)
                                  for p in pts),
                    capture_output=True, text=True, check=True).stdout
                pm = np.array([[float(v) for v in line.split()]
                               for line in out.splitlines()])
                worst = 0.0
                for p, q in zip(pts, pm):
                    it = mi.Interaction3f()
                    it.p = mi.Point3f(*p)
                    if ch == 1:
                        m = np.array([vol.eval_1(it)] * 3)
                    else:
                        m = np.array(vol.eval(it))
                    worst = max(worst, float(np.max(np.abs(m - q))))
                ok = worst <= 1e-5
                fails += not ok
                print("%s %-9s %-6s %s  max |pm - mitsuba| %.2g over %d "
                      "points" % (name, filt, wrap, "ok  " if ok else "FAIL",
                                  worst, len(pts)))
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
