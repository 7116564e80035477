#!/usr/bin/env python3
"""emitter_scenes.py: write the scenes that check pm's envmap and
directional emitters against Mitsuba 3.

    emitter_scenes.py DIR

Writes DIR/sky.exr, a 64x32 latitude-longitude map made here (a blue
gradient from zenith to horizon, a dim brown ground, and a bright 4x3
texel "sun" 40 degrees above the horizon, off-centre in u so that a wrong
u convention moves the shadows), and three scenes that use it or a
directional light: envmap.xml (the map turned by to_world and scaled,
lighting a diffuse ground and two diffuse spheres floating above it, seen
from above), envmap-view.xml (the same map seen directly, a wide view of
the sun and the horizon; envmap-view-hdr.xml the same from sky.hdr, the
map in Radiance's RGBE format; envmap-view-png.xml from an 8-bit sRGB
PNG), envmap-glass.xml (one sphere of glass,
for the sun's caustics), spot-envmap.xml (the map dimmed, and a
small spot light), envmap-flat.xml (a map of one
colour: it must light as a constant emitter does) and directional.xml (a
directional light and a dim constant sky on the same objects).  Every
scene takes $res and $spp like data/*.xml.

The spheres float 0.3 above the ground: where a sphere touches the
ground, pm's photon mode is biased bright in the contact shadow (about
+3% there, 17 sigma at 128x128, 1M photons), with a constant emitter
just as with these, which is a matter of the photon estimate, not of the
emitters these scenes check.  Nor is a rough metal among them: light
it reflects onto the ground comes, in photon mode, from an irradiance
lookup on the metal that is exact only under uniform light (-3% on the
ground below such a sphere here, with a constant emitter too).  No glass
under the directional light either: Mitsuba's path tracer cannot find a
delta light through smooth glass, so it has no caustics there while pm's
photon mode has (+2% in the mean at 128x128, all of it around the sphere;
pm's path tracer agrees with Mitsuba's).
"""

import os
import sys

import numpy as np


def sky(w=64, h=32):
    img = np.zeros((h, w, 3), dtype=np.float32)
    for y in range(h):
        theta = (y + 0.5) / h * np.pi
        if theta < np.pi / 2:
            t = theta / (np.pi / 2)
            img[y, :] = (0.25 + 0.35 * t, 0.4 + 0.3 * t, 0.9 - 0.2 * t)
        else:
            img[y, :] = (0.12, 0.09, 0.06)
    # the sun: rows around 50 degrees from the zenith, columns 44..47
    y0 = int(round(50.0 / 180.0 * h))
    img[y0:y0 + 3, 44:48] = (120.0, 100.0, 70.0)
    return img


def head(eye, target, up, fov):
    return """<scene version="3.0.0">
	<default name="spp" value="64"/>
	<default name="res" value="256"/>
	<integrator type="path"/>
	<sensor type="perspective">
		<float name="fov" value="%s"/>
		<transform name="to_world">
			<lookat origin="%s" target="%s" up="%s"/>
		</transform>
		<sampler type="independent">
			<integer name="sample_count" value="$spp"/>
		</sampler>
		<film type="hdrfilm">
			<integer name="width" value="$res"/>
			<integer name="height" value="$res"/>
			<rfilter type="box"/>
		</film>
	</sensor>
""" % (fov, eye, target, up)


# Looking straight down on the ground: its rim, where a photon estimate
# is biased dark (half its neighbourhood is empty), stays out of view.
HEAD = head("0, 8, 0", "0, 0, 0", "0, 0, -1", 40)

OBJECTS = """	<shape type="disk">
		<transform name="to_world">
			<scale value="4"/>
			<rotate x="1" angle="-90"/>
		</transform>
		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.5, 0.5, 0.45"/>
		</bsdf>
	</shape>
	<shape type="sphere">
		<point name="center" x="-0.8" y="1.0" z="0"/>
		<float name="radius" value="0.7"/>
		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.7, 0.4, 0.3"/>
		</bsdf>
	</shape>
	<shape type="sphere">
		<point name="center" x="0.9" y="0.9" z="0.3"/>
		<float name="radius" value="0.6"/>
		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.3, 0.5, 0.7"/>
		</bsdf>
	</shape>
</scene>
"""


ENVMAP = """	<emitter type="envmap">
		<string name="filename" value="sky.exr"/>
		<float name="scale" value="1.5"/>
		<transform name="to_world">
			<rotate y="1" angle="-35"/>
		</transform>
	</emitter>
"""


def main():
    if len(sys.argv) != 2:
        print("usage: emitter_scenes.py DIR", file=sys.stderr)
        return 2
    d = sys.argv[1]
    os.makedirs(d, exist_ok=True)
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.Bitmap(sky()).write(os.path.join(d, "sky.exr"))
    # the same map as Radiance HDR (RGBE, run-length scanlines), and as
    # an 8-bit sRGB PNG (the sun clipped to white)
    mi.Bitmap(sky()).write(os.path.join(d, "sky.hdr"))
    mi.Bitmap(np.clip(sky(), 0.0, 1.0)).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True).write(
        os.path.join(d, "sky.png"))
    flat = np.full((16, 32, 3), (0.6, 0.7, 0.9), dtype=np.float32)
    mi.Bitmap(flat).write(os.path.join(d, "flat.exr"))
    with open(os.path.join(d, "envmap.xml"), "w") as f:
        f.write(HEAD + ENVMAP + OBJECTS)
    # The map itself, seen around the sun and the horizon, with nothing
    # in front of it but a sphere out of view that gives the scene its
    # extent: its mapping and to_world, checked pixel by pixel.
    with open(os.path.join(d, "envmap-view.xml"), "w") as f:
        f.write(head("0, 0, 0", "-1, 0.3, -0.6", "0, 1, 0", 100) +
                ENVMAP + """	<shape type="sphere">
		<point name="center" x="0" y="0" z="50"/>
	</shape>
</scene>
""")
    with open(os.path.join(d, "envmap-view-hdr.xml"), "w") as f:
        f.write(head("0, 0, 0", "-1, 0.3, -0.6", "0, 1, 0", 100) +
                ENVMAP.replace("sky.exr", "sky.hdr") + """	<shape type="sphere">
		<point name="center" x="0" y="0" z="50"/>
	</shape>
</scene>
""")
    # Glass under the map: caustics of the map's sun, which the caustic
    # pass aims at the sphere.
    with open(os.path.join(d, "envmap-view-png.xml"), "w") as f:
        f.write(head("0, 0, 0", "-1, 0.3, -0.6", "0, 1, 0", 100) +
                ENVMAP.replace("sky.exr", "sky.png") + """	<shape type="sphere">
		<point name="center" x="0" y="0" z="50"/>
	</shape>
</scene>
""")
    with open(os.path.join(d, "envmap-glass.xml"), "w") as f:
        f.write(HEAD + ENVMAP + OBJECTS.replace("""		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.7, 0.4, 0.3"/>
		</bsdf>""", """		<bsdf type="dielectric"/>"""))
    with open(os.path.join(d, "envmap-flat.xml"), "w") as f:
        f.write(HEAD + """	<emitter type="envmap">
		<string name="filename" value="flat.exr"/>
	</emitter>
""" + OBJECTS)
    # A small spot light under the dimmed map: light selection must not
    # starve the spot (emitters.sh compares the noise with Mitsuba's).
    with open(os.path.join(d, "spot-envmap.xml"), "w") as f:
        f.write(HEAD + ENVMAP.replace('value="1.5"', 'value="0.05"') +
                """	<emitter type="spot">
		<rgb name="intensity" value="40"/>
		<float name="cutoff_angle" value="15"/>
		<transform name="to_world">
			<lookat origin="0, 5, 0.01" target="0, 0, 0"/>
		</transform>
	</emitter>
""" + OBJECTS)
    with open(os.path.join(d, "directional.xml"), "w") as f:
        f.write(HEAD + """	<emitter type="directional">
		<vector name="direction" x="-0.5" y="-1" z="-0.4"/>
		<rgb name="irradiance" value="3, 2.8, 2.5"/>
	</emitter>
	<emitter type="constant">
		<rgb name="radiance" value="0.15, 0.2, 0.3"/>
	</emitter>
""" + OBJECTS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
