#!/usr/bin/env python3
"""null_box_nee.py: Mitsuba 3's volpath against quadrature where light is
scattered once just under a null-BSDF box's top face, 0.24 under the light
(docs/media.md, "smoke's +0.28% was Mitsuba's").

    build/venv/bin/python tests/mitsuba/null_box_nee.py [bin/pm-render]

data/smoke.xml with its smoke replaced by a homogeneous medium (sigma_t 1,
albedo 0.8, HG g = 0.4) in the same null box, at max_depth 2 and 64x64.
Row 12, columns 24-40, sees only the box's top 0.03 in front of a black
ceiling, so its red is single scattering alone, which is integrated here
by the midpoint rule (over the pixel, the camera ray and the light).
Prints that, Mitsuba's with the medium's sample_emitters on and off, and
pm-render's (4 seeds each, mean and standard error).
"""
import os, re, subprocess, sys, tempfile
import numpy as np
import mitsuba as mi

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RES, ROW, C0, C1 = 64, 12, 24, 41
ST, SS, G, LE = 1.0, 0.8, 0.4, 17.0
LO, HI = np.array([-0.5, -0.05, -0.5]), np.array([0.5, 1.75, 0.5])


def scene_text(nee):
    s = open(os.path.join(ROOT, "data", "smoke.xml")).read()
    return re.sub(r'<medium type="heterogeneous" id="smoke">.*?</medium>',
                  '<medium type="homogeneous" id="smoke"><boolean name='
                  '"sample_emitters" value="%s"/><rgb name="albedo" value='
                  '"0.8"/><float name="sigma_t" value="1"/><phase type="hg">'
                  '<float name="g" value="0.4"/></phase></medium>'
                  % ("true" if nee else "false"), s, flags=re.S)


def quadrature(ns=6, nt=200, nl=48):
    tanh = np.tan(np.radians(39.3 / 2))
    lx = (np.arange(nl) + 0.5) / nl * 0.5 - 0.25
    lz = (np.arange(nl) + 0.5) / nl * 0.4 - 0.2
    X, Z = np.meshgrid(lx, lz)
    L = np.stack([X.ravel(), np.full(X.size, 1.99), Z.ravel()], -1)
    dA = 0.2 / len(L)
    cam = np.array([0.0, 1.0, 3.8])
    out = []
    for col in range(C0, C1):
        tot = 0.0
        for a in range(ns):
            for b in range(ns):
                u = (col + (b + 0.5) / ns) / RES * 2 - 1
                v = 1 - (ROW + (a + 0.5) / ns) / RES * 2
                d = np.array([u * tanh, v * tanh, -1.0])
                d /= np.linalg.norm(d)
                with np.errstate(divide="ignore"):
                    t0, t1 = (LO - cam) / d, (HI - cam) / d
                tn = np.max(np.minimum(t0, t1)); tf = np.min(np.maximum(t0, t1))
                if not tf > tn:
                    continue
                ts = tn + (np.arange(nt) + 0.5) / nt * (tf - tn)
                P = cam + ts[:, None] * d
                V = L[None] - P[:, None]
                dist = np.linalg.norm(V, axis=-1)
                w = V / dist[..., None]
                with np.errstate(divide="ignore", invalid="ignore"):
                    ex = np.nanmin(np.maximum((HI - P[:, None]) / w,
                                              (LO - P[:, None]) / w), axis=-1)
                tr = np.exp(-ST * np.minimum(ex, dist))
                c = np.sum(d * w, axis=-1)   # light's travel -w, then -d
                ph = (1 - G * G) / (4 * np.pi * (1 + G * G - 2 * G * c) ** 1.5)
                Ls = SS * np.sum(LE * ph * tr * w[..., 1] / dist ** 2 * dA, axis=1)
                tot += np.sum(np.exp(-ST * (ts - tn)) * Ls) * (tf - tn) / nt
        out.append(tot / ns / ns)
    return np.mean(out)


def stat(vals):
    v = np.array(vals)
    return "%.4f +- %.4f" % (v.mean(), v.std(ddof=1) / np.sqrt(len(v)))


def main():
    pm = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "bin", "pm-render")
    mi.set_variant("scalar_rgb")
    print("quadrature        %.4f" % quadrature())
    with tempfile.TemporaryDirectory() as tmp:
        for nee in (True, False):
            f = os.path.join(tmp, "box-%d.xml" % nee)
            open(f, "w").write(scene_text(nee))
            sc = mi.load_file(f, res=str(RES), spp="1024", max_depth="2")
            m = [np.array(mi.render(sc, spp=1024, seed=s))[ROW, C0:C1, 0].mean()
                 for s in range(4)]
            print("Mitsuba, sample_emitters %-5s %s" % (nee, stat(m)))
        f = os.path.join(tmp, "box-1.xml")
        p = []
        for s in range(1, 5):
            exr = os.path.join(tmp, "pm.exr")
            subprocess.run([pm, "-q", "-f", "--spp", "256", "--size", "64x64",
                            "-D", "res=64", "-D", "max_depth=2", "--seed",
                            str(s), "-o", exr, f], check=True)
            p.append(np.array(mi.Bitmap(exr))[ROW, C0:C1, 0].mean())
        print("pm-render, sample_emitters true  %s" % stat(p))


if __name__ == "__main__":
    main()
