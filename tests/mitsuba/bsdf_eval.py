#!/usr/bin/env python3
"""bsdf_eval.py: pm's principled and principledthin against Mitsuba 3's,
point by point.

    bsdf_eval.py BSDFEVAL DIR

For each parameter set below, writes a one-sphere scene with that <bsdf>
into DIR, and evaluates eval() (f |cos theta_o|, radiance) and pdf() at
4000 pairs of directions drawn uniformly over the sphere (reflection,
transmission, from outside and inside) in Mitsuba (scalar_rgb) and
through BSDFEVAL (pm, tests/mitsuba/bsdfeval.c).  They must agree to
float rounding: relative 1e-3 plus 1e-5 (values reach 1e4 near the
specular peaks, where float's own rounding of the half vector moves
them by more than 1e-5 relative).  Prints one line per case; exit status
1 if any disagrees.
"""
import os
import subprocess
import sys

import numpy as np

CASES = {
    "principled-default": ("principled", {}),
    "principled-plastic": ("principled", {
        "base_color": "rgb:0.8,0.3,0.1", "roughness": 0.3, "specular": 0.7,
        "spec_tint": 0.4, "sheen": 0.6, "sheen_tint": 0.5}),
    "principled-metal": ("principled", {
        "base_color": "rgb:0.9,0.6,0.2", "metallic": 1.0, "roughness": 0.2,
        "anisotropic": 0.7}),
    "principled-glass": ("principled", {
        "base_color": "rgb:0.9,0.95,0.7", "spec_trans": 0.8, "eta": 1.45,
        "roughness": 0.25, "metallic": 0.1}),
    "principled-coat": ("principled", {
        "base_color": "rgb:0.2,0.4,0.8", "clearcoat": 0.9,
        "clearcoat_gloss": 0.6, "flatness": 0.6, "roughness": 0.6,
        "metallic": 0.3, "spec_tint": 0.2}),
    "principled-all": ("principled", {
        "base_color": "rgb:1.0,1.0,1.0", "metallic": 0.7, "specular": 0.6,
        "roughness": 0.2, "spec_tint": 0.4, "anisotropic": 0.5,
        "sheen": 0.3, "sheen_tint": 0.2, "clearcoat": 0.6,
        "clearcoat_gloss": 0.3, "spec_trans": 0.4,
        "main_specular_sampling_rate": 0.7, "clearcoat_sampling_rate": 2.0,
        "diffuse_reflectance_sampling_rate": 1.5}),
    "thin-default": ("principledthin", {}),
    "thin-doc": ("principledthin", {
        "base_color": "rgb:0.7,0.1,0.1", "roughness": 0.15,
        "spec_tint": 0.1, "anisotropic": 0.5, "spec_trans": 0.8,
        "diff_trans": 0.3, "eta": 1.33}),
    "thin-leaf": ("principledthin", {
        "base_color": "rgb:0.3,0.7,0.2", "roughness": 0.6, "sheen": 0.5,
        "sheen_tint": 0.7, "flatness": 0.4, "diff_trans": 1.2,
        "spec_trans": 0.2, "eta": 1.6,
        "diffuse_transmittance_sampling_rate": 0.5,
        "specular_reflectance_sampling_rate": 2.0}),
}


def xml_params(params):
    out = []
    for k, v in params.items():
        if isinstance(v, str) and v.startswith("rgb:"):
            out.append('<rgb name="%s" value="%s"/>' % (k, v[4:]))
        else:
            out.append('<float name="%s" value="%r"/>' % (k, v))
    return "\n    ".join(out)


def main():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    tool, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(5)
    n = 4000
    v = rng.normal(size=(n, 6))
    wi = v[:, :3] / np.linalg.norm(v[:, :3], axis=1)[:, None]
    wo = v[:, 3:] / np.linalg.norm(v[:, 3:], axis=1)[:, None]
    # half the pairs near the mirror or refracted peak, where the
    # specular lobes are
    k = n // 2
    wo[:k] = np.stack([-wi[:k, 0], -wi[:k, 1], wi[:k, 2]], 1) + \
        0.2 * rng.normal(size=(k, 3))
    wo[:k // 2, 2] *= -1.0
    wo /= np.linalg.norm(wo, axis=1)[:, None]
    wi, wo = wi.astype(np.float32), wo.astype(np.float32)
    text = "\n".join(" ".join("%r" % float(x) for x in list(a) + list(b))
                     for a, b in zip(wi, wo)) + "\n"
    failed = 0
    for name, (kind, params) in CASES.items():
        bsdf = '<bsdf type="%s">\n    %s\n</bsdf>' % (kind,
                                                     xml_params(params))
        scene = os.path.join(out, name + ".xml")
        with open(scene, "w") as f:
            f.write('<scene version="3.0.0">\n<shape type="sphere">\n%s\n'
                    '</shape>\n</scene>\n' % bsdf)
        mb = mi.load_string(bsdf.replace('<bsdf ', '<bsdf version="3.0.0" ',
                                         1))
        ctx = mi.BSDFContext()
        si = mi.SurfaceInteraction3f()
        ref = []
        for a, b in zip(wi, wo):
            si.wi = mi.Vector3f(*[float(x) for x in a])
            w = mi.Vector3f(*[float(x) for x in b])
            e = mb.eval(ctx, si, w)
            ref.append([float(e[0]), float(e[1]), float(e[2]),
                        float(mb.pdf(ctx, si, w))])
        ref = np.array(ref)
        res = subprocess.run([tool, scene], input=text, capture_output=True,
                             text=True)
        if res.returncode != 0:
            print("bsdf_eval: %s: %s" % (tool, res.stderr))
            return 1
        got = np.array([[float(x) for x in line.split()]
                        for line in res.stdout.split("\n") if line])
        diff = np.abs(got - ref)
        tol = 1e-3 * np.abs(ref) + 1e-5
        bad = np.any(diff > tol, axis=1)
        failed += int(bad.any())
        print("bsdf_eval: %s: max |pm - Mitsuba| %.2g (eval) %.2g (pdf), "
              "mean eval %.4g vs %.4g, %d of %d pairs beyond tolerance"
              % (name, diff[:, :3].max(), diff[:, 3].max(),
                 got[:, :3].mean(), ref[:, :3].mean(), int(bad.sum()), n))
        for i in np.nonzero(bad)[0][:3]:
            print("    wi %s wo %s: pm %s Mitsuba %s" % (wi[i], wo[i], got[i],
                                                       ref[i]))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
