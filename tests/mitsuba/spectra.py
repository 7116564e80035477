#!/usr/bin/env python3
"""spectra.py: pm reads spectra as Mitsuba 3's RGB variants do.

    spectra.py [--pm-render bin/pm-render] [--workdir DIR]

Each case puts one <spectrum> into a tiny scene that both renderers see
without noise: the camera looks straight at a constant emitter (an
emitter's spectrum), or at a mirror (a smooth conductor, material none)
that reflects a white constant emitter (a reflectance, as the mirror's
specular_reflectance; or a conductor's eta and k, which Mitsuba does not
clamp to 1).  pm-render and Mitsuba (scalar_rgb) render it at 1
sample per pixel and their mean colours must agree to 1e-4 (relative).

Mitsuba's RGB variants refuse to render a blackbody; for those cases the
reference is what a spectral variant shows: Mitsuba's own blackbody
spectrum (scalar_spectral) integrated by Mitsuba's own
spectrum_list_to_srgb, unweighted and unbounded as for any emitter.

Prints one line per case and exits 1 if any disagrees, 2 if Mitsuba or
numpy cannot be imported.
"""

import argparse
import os
import subprocess
import sys
import tempfile

try:
    import numpy as np
    import mitsuba as mi
except ImportError as e:
    print("spectra.py: %s" % e, file=sys.stderr)
    sys.exit(2)

SPD = """# wavelength (nm) and value, irregularly spaced
380 0.05
420 0.6
455 0.3
530 0.8

610 0.15
700 0.7
780 0.2
"""

# (name, role, the <spectrum> element without its name attribute)
CASES = [
    ("refl-uniform", "refl", 'value="0.3"'),
    ("refl-list", "refl", 'value="400:0.1, 500:0.9, 600:0.2, 700:0.5"'),
    ("refl-flat", "refl", 'value="360:0.5, 830:0.5"'),
    ("refl-file", "refl", 'filename="s.spd"'),
    ("refl-clamped", "refl", 'value="500:0, 510:1, 520:0"'),
    # a conductor's eta and k are not clamped to 1
    ("conductor-eta-k", "etak", ('value="400:0.3, 550:1.1, 700:2.5"',
                                 'value="400:2.2, 550:2.9, 700:4.1"')),
    ("emit-uniform", "emit", 'value="2"'),
    ("emit-list", "emit", 'value="400:0.1, 500:0.9, 600:0.2, 700:0.5"'),
    ("emit-flat", "emit", 'value="360:0.5 830:0.5"'),
    ("emit-file", "emit", 'filename="s.spd"'),
    ("emit-blackbody", "bb", (4000.0, None, None)),
    # Mitsuba's RGB variants cannot render regular and irregular spectra;
    # Mitsuba's reference is the same list given as value="w:v, ...".
    ("refl-regular", "refl",
     'type="regular"><float name="wavelength_min" value="400"/>'
     '<float name="wavelength_max" value="700"/>'
     '<string name="values" value="0.1, 0.9, 0.2, 0.5"/></spectrum',
     'value="400:0.1, 500:0.9, 600:0.2, 700:0.5"'),
    ("emit-irregular", "emit",
     'type="irregular"><string name="wavelengths" value="380, 420, 455, '
     '530, 610, 700, 780"/><string name="values" value="0.05 0.6 0.3 0.8 '
     '0.15 0.7 0.2"/></spectrum', 'filename="s.spd"'),
    ("emit-d65", "emit", 'type="d65"><rgb name="color" value="0.5, 0.2, '
     '0.1"/><float name="scale" value="3"/></spectrum'),
    ("refl-srgb", "refl", 'type="srgb"><rgb name="color" value="0.5, 0.2, '
     '0.1"/></spectrum'),
    ("emit-blackbody-range", "bb", (6500.0, 450.0, 650.0)),
]


def scene(role, spec):
    cam = ('<sensor type="perspective"><float name="fov" value="20"/>'
           '<film type="hdrfilm"><integer name="width" value="4"/>'
           '<integer name="height" value="4"/><rfilter type="box"/>'
           '</film></sensor>')
    # pm needs some geometry for the environment's extent: a sphere
    # out of sight, and out of the mirror's sight.
    behind = ('<shape type="sphere"><point name="center" x="50" y="0" '
              'z="0"/></shape>')
    if role in ("refl", "etak"):
        if role == "refl":
            params = ('<string name="material" value="none"/>'
                      '<spectrum name="specular_reflectance" %s%s>'
                      % (spec, "" if spec.endswith("</spectrum") else "/"))
        else:
            params = ('<spectrum name="eta" %s/><spectrum name="k" %s/>'
                      % spec)
        body = ('<emitter type="constant"><rgb name="radiance" value="1"/>'
                '</emitter><shape type="rectangle"><transform name="to_world">'
                '<rotate y="1" angle="180"/><translate z="5"/></transform>'
                '<bsdf type="conductor">%s</bsdf></shape>' % params)
    else:
        if role == "bb":
            t, lo, hi = spec
            inner = '<float name="temperature" value="%g"/>' % t
            if lo is not None:
                inner += ('<float name="wavelength_min" value="%g"/>'
                          '<float name="wavelength_max" value="%g"/>'
                          % (lo, hi))
            spec = 'type="blackbody">%s</spectrum' % inner
            el = '<spectrum name="radiance" %s>' % spec
        elif spec.endswith("</spectrum"):
            el = '<spectrum name="radiance" %s>' % spec
        else:
            el = '<spectrum name="radiance" %s/>' % spec
        body = '<emitter type="constant">%s</emitter>' % el
    return ('<scene version="3.0.0"><integrator type="path"/>%s%s%s</scene>'
            % (cam, body, behind))


def mean_rgb(path):
    a = np.array(mi.Bitmap(path), dtype=np.float64)
    return a.reshape(-1, a.shape[-1])[:, :3].mean(0)


def blackbody_reference(t, lo, hi):
    """Mitsuba's blackbody, integrated by Mitsuba as an emitter's list."""
    mi.set_variant("scalar_spectral")
    props = {"type": "blackbody", "temperature": t}
    if lo is not None:
        props["wavelength_min"] = lo
        props["wavelength_max"] = hi
    bb = mi.load_dict(props)
    # Mitsuba's integration samples 1000 points over 360..830 nm; a list
    # on exactly those points is integrated exactly as the spectrum is.
    wl = [360.0 + i / 999.0 * 470.0 for i in range(1000)]
    vals = []
    si = mi.SurfaceInteraction3f()
    for i in range(0, 1000, 4):
        w = wl[i:i + 4] + [wl[-1]] * (4 - len(wl[i:i + 4]))
        si.wavelengths = mi.Spectrum(w)
        v = bb.eval(si)
        vals += [float(v[k]) for k in range(len(wl[i:i + 4]))]
    mi.set_variant("scalar_rgb")
    return np.array(mi.spectrum_list_to_srgb(wl, vals, False, False),
                    dtype=np.float64)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--pm-render", default="bin/pm-render")
    p.add_argument("--workdir", default=None)
    a = p.parse_args()
    pm_render = os.path.abspath(a.pm_render)
    work = a.workdir or tempfile.mkdtemp(prefix="pm-spectra-")
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(work, "s.spd"), "w") as f:
        f.write(SPD)
    mi.set_variant("scalar_rgb")
    failed = 0
    for case in CASES:
        name, role, spec = case[:3]
        xml = os.path.join(work, name + ".xml")
        with open(xml, "w") as f:
            f.write(scene(role, spec))
        # the scene Mitsuba renders, when it cannot render pm's
        mi_xml = xml
        if len(case) > 3:
            mi_xml = os.path.join(work, name + "-mi.xml")
            with open(mi_xml, "w") as f:
                f.write(scene(role, case[3]))
        out = os.path.join(work, name + "-pm.exr")
        r = subprocess.run([pm_render, xml, "-o", out, "--spp", "1", "-q",
                            "-f"], capture_output=True, text=True)
        if r.returncode != 0:
            print("FAIL %s: pm-render: %s" % (name, r.stderr.strip()))
            failed += 1
            continue
        pm = mean_rgb(out)
        if role == "bb":
            ref = blackbody_reference(*spec)
        else:
            img = mi.render(mi.load_file(mi_xml), spp=1)
            ref = np.array(img, dtype=np.float64).reshape(-1, 3).mean(0)
        tol = 1e-4 * np.maximum(np.abs(ref), 1e-3)
        # a black reference would prove nothing
        ok = bool(np.all(np.abs(pm - ref) <= tol)) and ref.sum() > 0
        failed += not ok
        print("%s %s: pm %s Mitsuba %s" % ("ok  " if ok else "FAIL", name,
              np.array2string(pm, precision=6),
              np.array2string(ref, precision=6)))
    print("spectra: %d of %d cases agree" % (len(CASES) - failed, len(CASES)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
