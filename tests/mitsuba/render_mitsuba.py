#!/usr/bin/env python3
"""render_mitsuba.py: render a scene file with Mitsuba 3, as the reference
that pm-render is checked against.

    render_mitsuba.py SCENE.xml OUT.exr [--spp N] [-D name=value ...]
                      [--variant V] [--seed N] [--light-scale F] [--no-cache]
                      [--integrator path|ptracer] [--key-scope scene]
                      [--moments] [--record DIR]

The scene is rendered with its own integrator (the Cornell boxes use `path`),
so both renderers read exactly the same file. OUT.exr holds linear RGB float32.

Reference renders are slow to make and never change for a given input, so
they are cached under build/mitsuba-cache/, keyed by a hash of the scene
file and the files it names (includes, meshes, textures, with $name resolved
from <default> and -D), so that a reference survives edits to other files
beside the scene, and of the options that change the picture. --key-scope
scene is that key, the only one (every caller passes it; the key holds it,
so that renders cached and committed under it stay valid). --light-scale
multiplies the first emitter's radiance, which the self-test uses to prove
that the comparison notices a 5% brighter light. --integrator replaces the scene's integrator by Mitsuba's
`path` or `ptracer` with unlimited depth. The cache's .json records the
seconds spent loading the scene and rendering it, which the accuracy study
reads as Mitsuba's wall time. --moments (a scene under Mitsuba's `moment`
integrator) writes instead of RGB the per-pixel variance of one sample,
m2 - m1^2 of the moment channels (CIE XYZ), as three channels.

Renders that take minutes are also committed, under tests/mitsuba/references/
(the same KEY.exr and KEY.json, looked up after the build cache and never
written to but by --record): a fresh clone, as CI has, reads them instead of
rendering for twenty minutes. A committed render is Mitsuba's own output for
exactly that key (scene files, options, variant and Mitsuba version), so an
edited scene or another Mitsuba misses it and renders afresh. --record DIR
copies the render's cache entry, made now or found, into DIR
(`make mitsuba-references` remakes the committed set this way).
"""

import argparse
import hashlib
import json
import os
import shutil
import sys
import time
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CACHE = os.environ.get("PM_MITSUBA_CACHE",
                       os.path.join(ROOT, "build", "mitsuba-cache"))

# Committed renders, read-only (see above).
REFERENCES = os.environ.get("PM_MITSUBA_REFERENCES",
                            os.path.join(HERE, "references"))

# Bumped when this script changes what it writes for the same key.
CACHE_FORMAT = "1"


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("out")
    p.add_argument("--spp", type=int, default=None,
                   help="samples per pixel (default: the scene's own)")
    p.add_argument("-D", dest="defines", action="append", default=[],
                   metavar="NAME=VALUE", help="scene parameter ($NAME)")
    p.add_argument("--variant", default=None,
                   help="Mitsuba variant (default: build/venv/pm-variant, "
                   "else scalar_rgb)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--light-scale", type=float, default=1.0,
                   help="multiply the first emitter's radiance by this")
    p.add_argument("--no-cache", action="store_true")
    p.add_argument("--meta", default=None, metavar="FILE",
                   help="also write the render's record (seconds, variant, "
                   "cache key) as JSON to FILE")
    p.add_argument("--integrator", choices=("path", "ptracer"), default=None,
                   help="replace the scene's integrator (max_depth -1)")
    p.add_argument("--key-scope", choices=("scene",), default="scene",
                   help="the cache key: the scene and the files it names")
    p.add_argument("--moments", action="store_true",
                   help="write the moment integrator's variance, m2 - m1^2")
    p.add_argument("--record", default=None, metavar="DIR",
                   help="copy the render's cache entry (KEY.exr, KEY.json) "
                   "into DIR")
    p.add_argument("-q", "--quiet", action="store_true")
    return p.parse_args(argv)


def default_variant():
    env = os.environ.get("MITSUBA_VARIANT")
    if env:
        return env
    path = os.path.join(sys.prefix, "pm-variant")
    try:
        with open(path) as f:
            v = f.read().strip()
            if v:
                return v
    except OSError:
        pass
    return "scalar_rgb"


def parse_defines(items):
    out = {}
    for d in items:
        if "=" not in d:
            sys.exit("render_mitsuba: -D wants NAME=VALUE, got %r" % d)
        k, v = d.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def resolve(name, defines):
    """Replaces each $key of name by its value in defines; None when some
    reference stays unresolved."""
    for k in sorted(defines, key=len, reverse=True):
        name = name.replace("$" + k, defines[k])
    return None if "$" in name else name


def referenced_files(scene_path, seen=None, defines=None, resolve_all=False):
    """Files a scene names (includes and `filename` strings), followed
    through includes; `$name` is resolved from -D, then from the scene's
    <default> elements, and skipped when neither has it."""
    seen = set() if seen is None else seen
    defines = {} if defines is None else defines
    scene_path = os.path.abspath(scene_path)
    if scene_path in seen:
        return seen
    seen.add(scene_path)
    base = os.path.dirname(scene_path)
    try:
        tree = ET.parse(scene_path)
    except (OSError, ET.ParseError):
        return seen
    values = {el.get("name"): el.get("value", "")
              for el in tree.iter("default") if el.get("name")}
    values.update(defines)
    for el in tree.iter():
        name = None
        if el.tag == "include":
            name = el.get("filename")
        elif el.tag == "string" and el.get("name") == "filename":
            name = el.get("value")
        if name and "$" in name:
            name = resolve(name, values) if resolve_all else None
        if not name:
            continue
        path = name if os.path.isabs(name) else os.path.join(base, name)
        if not os.path.isfile(path):
            continue
        if el.tag == "include":
            referenced_files(path, seen, defines, resolve_all)
        else:
            seen.add(os.path.abspath(path))
    return seen


def cache_key(args, defines, variant, mitsuba_version):
    """Content hash of the scene's inputs and the options that matter."""
    h = hashlib.sha256()
    scene = os.path.abspath(args.scene)
    sdir = os.path.dirname(scene)
    files = referenced_files(scene, defines=defines, resolve_all=True)
    for path in sorted(files):
        h.update(path.encode() if not path.startswith(sdir + os.sep)
                 else os.path.relpath(path, sdir).encode())
        h.update(b"\0")
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        h.update(b"\0")
    opts = {
        "format": CACHE_FORMAT,
        "scene": os.path.relpath(scene, sdir),
        "spp": args.spp,
        "defines": sorted(defines.items()),
        "variant": variant,
        "seed": args.seed,
        "light_scale": args.light_scale,
        "mitsuba": mitsuba_version,
    }
    # New options enter the key only when used, so that the keys of
    # renders cached before they existed stay valid.
    if args.integrator is not None:
        opts["integrator"] = args.integrator
    opts["key_scope"] = args.key_scope
    if args.moments:
        opts["moments"] = True
    h.update(json.dumps(opts, sort_keys=True).encode())
    return h.hexdigest()[:32]


def scale_first_emitter(mi, scene, factor):
    emitters = scene.emitters()
    if not emitters:
        sys.exit("render_mitsuba: --light-scale: the scene has no emitter")
    params = mi.traverse(emitters[0])
    for key in ("radiance.value", "intensity.value", "irradiance.value",
                "radiance.data", "data"):
        if key in params:
            params[key] = params[key] * factor
            params.update()
            return
    sys.exit("render_mitsuba: --light-scale: no radiance parameter in %s"
             % list(params.keys()))


def render(args, defines, variant, out):
    import mitsuba as mi
    import numpy as np
    mi.set_variant(variant)
    t_load = time.time()
    scene = mi.load_file(args.scene, **defines)
    if args.light_scale != 1.0:
        scale_first_emitter(mi, scene, args.light_scale)
    t0 = time.time()
    load_seconds = t0 - t_load
    kw = {"seed": args.seed}
    if args.spp is not None:
        kw["spp"] = args.spp
    if args.integrator is not None:
        kw["integrator"] = mi.load_dict({"type": args.integrator,
                                         "max_depth": -1})
    # Dr.Jit holds a wavefront of pixels x spp; past about 2^27 samples
    # that outgrows a small machine's memory, so long references are
    # rendered in passes of independent seeds and averaged.
    npix = 1
    for v in scene.sensors()[0].film().crop_size():
        npix *= int(v)
    spp = args.spp if args.spp is not None else \
        scene.sensors()[0].sampler().sample_count()
    per = max(1, min(spp, (1 << 27) // max(npix, 1)))
    if spp <= per:
        arr = np.array(mi.render(scene, **kw), dtype=np.float64)
    else:
        arr, done, i = None, 0, 0
        while done < spp:
            n = min(per, spp - done)
            kw2 = dict(kw, spp=n, seed=args.seed * 100003 + i)
            part = np.array(mi.render(scene, **kw2), dtype=np.float64) * n
            arr = part if arr is None else arr + part
            done += n
            i += 1
        arr = arr / spp
    if args.moments:
        # The film's channels by name: R, G, B, then NAME.X.. and
        # m2_NAME.X.. of the moment integrator.
        film = scene.sensors()[0].film()
        names = [film.bitmap().struct_()[i].name
                 for i in range(arr.shape[2])]
        m2 = [i for i, n in enumerate(names) if n.startswith("m2_")]
        m1 = [names.index(names[i][3:]) for i in m2]
        if len(m2) != 3:
            sys.exit("render_mitsuba: --moments: no moment channels in %s"
                     % names)
        arr = arr[:, :, m2] - arr[:, :, m1] ** 2
    arr = arr.astype(np.float32)
    seconds = time.time() - t0
    if arr.ndim != 3 or arr.shape[2] < 3:
        sys.exit("render_mitsuba: expected an RGB film, got shape %s"
                 % (arr.shape,))
    arr = np.ascontiguousarray(arr[:, :, :3])
    bmp = mi.Bitmap(arr, pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.write(out)
    return seconds, load_seconds, arr.shape


def write_meta(path, meta, key):
    """The render's record, with its cache key, for --meta."""
    if path:
        with open(path, "w") as f:
            json.dump(dict(meta, key=key), f, indent=1)


def store(exr, exr_to, meta, meta_to):
    """Copies a render and writes its record, each by rename, so that a
    reader never finds half a file."""
    tmp = exr_to + ".tmp%d" % os.getpid()
    shutil.copyfile(exr, tmp)
    os.replace(tmp, exr_to)
    with open(meta_to + ".tmp", "w") as f:
        json.dump(meta, f, indent=1)
        f.write("\n")
    os.replace(meta_to + ".tmp", meta_to)


def record(where, exr, meta, key):
    """--record: the cache entry into WHERE, its scene path relative to
    the repository (a committed record names no one's checkout)."""
    if where is None:
        return
    os.makedirs(where, exist_ok=True)
    meta = dict(meta)
    scene = meta.get("scene")
    if scene and os.path.isabs(scene):
        rel = os.path.relpath(scene, ROOT)
        if not rel.startswith(".."):
            meta["scene"] = rel
    store(exr, os.path.join(where, key + ".exr"), meta,
          os.path.join(where, key + ".json"))


def main(argv):
    args = parse_args(argv)
    if not os.path.isfile(args.scene):
        sys.exit("render_mitsuba: no scene file %s" % args.scene)
    defines = parse_defines(args.defines)
    variant = args.variant or default_variant()
    import mitsuba
    version = mitsuba.__version__

    key = cache_key(args, defines, variant, version)
    if not args.no_cache:
        for where, what in ((CACHE, "cached"),
                            (REFERENCES, "committed reference")):
            cached = os.path.join(where, key + ".exr")
            meta_path = os.path.join(where, key + ".json")
            if not (os.path.isfile(cached) and os.path.isfile(meta_path)):
                continue
            shutil.copyfile(cached, args.out)
            with open(meta_path) as f:
                meta = json.load(f)
            write_meta(args.meta, meta, key)
            record(args.record, cached, meta, key)
            if not args.quiet:
                print("render_mitsuba: %s (%s %s; rendered in %.1f s with "
                      "mitsuba %s %s)" % (args.out, what, key,
                                          meta["seconds"], meta["mitsuba"],
                                          meta["variant"]))
            return 0

    seconds, load_seconds, shape = render(args, defines, variant, args.out)
    if not args.quiet:
        print("render_mitsuba: %s %dx%d spp=%s seed=%d in %.1f s "
              "(mitsuba %s %s)" % (args.out, shape[1], shape[0],
                                   args.spp if args.spp else "scene",
                                   args.seed, seconds, version, variant))
    meta = {"scene": os.path.abspath(args.scene), "spp": args.spp,
            "defines": defines, "seed": args.seed,
            "light_scale": args.light_scale, "variant": variant,
            "mitsuba": version, "seconds": round(seconds, 3),
            "load_seconds": round(load_seconds, 3),
            "integrator": args.integrator or "scene",
            "width": shape[1], "height": shape[0]}
    if not args.no_cache:
        os.makedirs(CACHE, exist_ok=True)
        cached = os.path.join(CACHE, key + ".exr")
        store(args.out, cached, meta, os.path.join(CACHE, key + ".json"))
        write_meta(args.meta, meta, key)
        record(args.record, cached, meta, key)
    elif args.meta:
        write_meta(args.meta, {"seconds": round(seconds, 3),
                               "load_seconds": round(load_seconds, 3),
                               "variant": variant, "mitsuba": version}, key)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
