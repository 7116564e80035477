#!/usr/bin/env python3
"""moments.py: the per-pixel variance of one sample, m2 - m1^2, from an EXR
that pm-render wrote for a scene under Mitsuba's `moment` integrator.

    moments.py IN.exr OUT.exr

IN holds NAME.X, NAME.Y, NAME.Z and m2_NAME.X, ... beside R, G and B (as
Mitsuba names them); OUT gets m2_NAME - NAME^2 for X, Y and Z as three
channels, what render_mitsuba.py --moments writes for Mitsuba's render,
so that compare.py can put the two side by side.
"""

import sys

import numpy as np


def main(argv):
    if len(argv) != 2:
        sys.exit("usage: moments.py IN.exr OUT.exr")
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(argv[0])
    arr = np.array(bmp, dtype=np.float64)
    names = [bmp.struct_()[i].name for i in range(arr.shape[2])]
    m2 = [i for i, n in enumerate(names) if n.startswith("m2_")]
    if len(m2) != 3:
        sys.exit("moments.py: %s: no moment channels in %s"
                 % (argv[0], names))
    m1 = [names.index(names[i][3:]) for i in m2]
    var = np.ascontiguousarray((arr[:, :, m2] - arr[:, :, m1] ** 2)
                               .astype(np.float32))
    mi.Bitmap(var, pixel_format=mi.Bitmap.PixelFormat.RGB).write(argv[1])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
