#!/usr/bin/env python3
"""emitter_scenes.py: write the scenes that check pm's envmap,
directional, textured and projector emitters against Mitsuba 3, and the
textures they use (see textured() below).

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


def pattern(w=8, h=6):
    """An image whose orientation shows: red grows along u (columns),
    green along v (rows, top first), and a blue block in the first row's
    first two texels."""
    img = np.zeros((h, w, 3), dtype=np.float32)
    for y in range(h):
        for x in range(w):
            img[y, x] = (0.1 + 0.9 * x / (w - 1), 0.1 + 0.8 * y / (h - 1),
                         0.1)
    img[0, 0:2] = (0.05, 0.1, 1.0)
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
    textured(d, mi)
    return 0


# Textured emitters and the textures pm reads besides checkerboard and
# bitmap; pattern.* is pattern() in the formats these read.
SPOT_TEX = """	<emitter type="spot">
		<rgb name="intensity" value="60"/>
		<float name="cutoff_angle" value="30"/>
		<texture type="bitmap" name="texture">
			<string name="filename" value="pattern.exr"/>
			<string name="filter_type" value="nearest"/>
		</texture>
		<transform name="to_world">
			<lookat origin="0.3, 5, 0.2" target="0, 0, 0" up="1, 0, 0"/>
		</transform>
	</emitter>
"""

# The image's edge lies beyond the view, and a dim sky lights the
# shadows, as in directional.xml: where only indirect light arrives
# beside a delta light's hard edge, photon mode's estimate is a few
# percent off almost nothing (10 of 768 blocks beyond 4 sigma of an
# otherwise noiseless image, in the spheres' umbra), a matter of the
# photon estimate, not of the projector.
PROJECTOR = """	<emitter type="constant">
		<rgb name="radiance" value="0.15, 0.2, 0.3"/>
	</emitter>
	<emitter type="projector">
		<texture type="bitmap" name="irradiance">
			<string name="filename" value="pattern.exr"/>
		</texture>
		<float name="scale" value="8"/>
		<float name="fov" value="70"/>
		<transform name="to_world">
			<lookat origin="1, 6, 1.5" target="0, 0, 0" up="0, 0, -1"/>
		</transform>
	</emitter>
"""

AREA_TEX = """	<shape type="rectangle">
		<transform name="to_world">
			<scale x="1.2" y="0.8"/>
			<rotate x="1" angle="20"/>
			<translate y="2.2" z="-2.5"/>
		</transform>
		<emitter type="area">
			<texture type="bitmap" name="radiance">
				<string name="filename" value="bright.exr"/>
			</texture>
		</emitter>
	</shape>
	<shape type="sphere">
		<point name="center" x="2.2" y="2.4" z="-1"/>
		<float name="radius" value="0.35"/>
		<emitter type="area">
			<texture type="checkerboard" name="radiance">
				<texture type="rawconstant" name="color0">
					<vector name="value" x="6" y="5" z="2"/>
				</texture>
				<rgb name="color1" value="0.5, 0.8, 1"/>
				<transform name="to_uv">
					<scale x="4" y="2"/>
				</transform>
			</texture>
		</emitter>
	</shape>
	<shape type="rectangle">
		<transform name="to_world">
			<scale value="6"/>
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

# A rectangle, not OBJECTS' disk, under the checkerboard: pm's disk is a
# fan of triangles whose uv, interpolated over each, bends the circles of
# constant radius into polygons (the squares' edges moved by a pixel or
# two at 256 x 256, 71 of 768 blocks beyond 4 sigma).
TEX_MORE = """	<emitter type="constant">
		<rgb name="radiance" value="1, 0.95, 0.9"/>
	</emitter>
	<shape type="rectangle">
		<transform name="to_world">
			<scale value="4"/>
			<rotate x="1" angle="-90"/>
		</transform>
		<bsdf type="diffuse">
			<texture type="checkerboard" name="reflectance">
				<texture type="bitmap" name="color0">
					<string name="filename" value="pattern.hdr"/>
					<string name="filter_type" value="nearest"/>
				</texture>
				<texture type="rawconstant" name="color1">
					<float name="value" value="0.15"/>
				</texture>
				<transform name="to_uv">
					<scale x="3" y="5"/>
				</transform>
			</texture>
		</bsdf>
	</shape>
	<shape type="sphere">
		<point name="center" x="-0.8" y="1.0" z="0"/>
		<float name="radius" value="0.7"/>
		<bsdf type="diffuse">
			<texture type="rawconstant" name="reflectance">
				<vector name="value" x="0.7" y="0.4" z="0.3"/>
			</texture>
		</bsdf>
	</shape>
	<shape type="sphere">
		<point name="center" x="0.9" y="0.9" z="0.3"/>
		<float name="radius" value="0.6"/>
		<bsdf type="dielectric">
			<texture type="bitmap" name="specular_transmittance">
				<string name="filename" value="pattern.png"/>
			</texture>
			<texture type="checkerboard" name="specular_reflectance">
				<rgb name="color0" value="1"/>
				<rgb name="color1" value="0.2"/>
				<transform name="to_uv">
					<scale x="6" y="3"/>
				</transform>
			</texture>
		</bsdf>
	</shape>
</scene>
"""


def ply_grid(path, n, half, vcol=None, fcol=None):
    """An n x n grid of squares, two triangles each, over [-half,
    half]^2 at z = 0 facing +z, as ASCII PLY; vcol(x, y) and fcol(i)
    give float r g b for vertices and for triangles."""
    verts = [(-half + 2 * half * i / n, -half + 2 * half * j / n)
             for j in range(n + 1) for i in range(n + 1)]
    tris = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            tris.append((a, a + 1, a + n + 2))
            tris.append((a, a + n + 2, a + n + 1))
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\n" % len(verts))
        f.write("property float x\nproperty float y\nproperty float z\n")
        if vcol:
            f.write("property float red\nproperty float green\n"
                    "property float blue\n")
        f.write("element face %d\n" % len(tris))
        f.write("property list uchar int vertex_indices\n")
        if fcol:
            f.write("property float r\nproperty float g\n"
                    "property float b\n")
        f.write("end_header\n")
        for x, y in verts:
            f.write("%g %g 0" % (x, y))
            if vcol:
                f.write(" %g %g %g" % vcol(x, y))
            f.write("\n")
        for k, t in enumerate(tris):
            f.write("3 %d %d %d" % t)
            if fcol:
                f.write(" %g %g %g" % fcol(k))
            f.write("\n")


# mesh_attribute: vertex colours on the ground, face colours on a
# panel, and (LAMP_ATTR) vertex colours as a light's radiance.
ATTRS = """	<shape type="ply">
		<string name="filename" value="ground.ply"/>
		<transform name="to_world">
			<rotate x="1" angle="-90"/>
		</transform>
		<bsdf type="diffuse">
			<texture type="mesh_attribute" name="reflectance">
				<string name="name" value="vertex_color"/>
			</texture>
		</bsdf>
	</shape>
	<shape type="ply">
		<string name="filename" value="panel.ply"/>
		<transform name="to_world">
			<rotate x="1" angle="-90"/>
			<translate x="-0.8" y="0.8" z="0.2"/>
		</transform>
		<bsdf type="diffuse">
			<texture type="mesh_attribute" name="reflectance">
				<string name="name" value="face_color"/>
				<float name="scale" value="0.9"/>
			</texture>
		</bsdf>
	</shape>
	<shape type="ply">
		<string name="filename" value="lamp.ply"/>
		<transform name="to_world">
			<rotate x="1" angle="90"/>
			<translate x="1" y="3" z="0.5"/>
		</transform>
		<emitter type="area">
			LAMP
		</emitter>
	</shape>
</scene>
"""

SKY = """	<emitter type="constant">
		<rgb name="radiance" value="0.3, 0.3, 0.35"/>
	</emitter>
"""

LAMP_ATTR = """<texture type="mesh_attribute" name="radiance">
				<string name="name" value="vertex_color"/>
				<float name="scale" value="4"/>
			</texture>"""


def textured(d, mi):
    """spot-tex.xml, projector.xml and projector-flat.xml over OBJECTS,
    area-tex.xml (a bitmap on a rectangle light seen from the front, a
    checkerboard on a small sphere light), tex-more.xml: under a
    constant sky, a checkerboard of an RGBE bitmap and a rawconstant, a
    rawconstant <vector>, and glass whose transmittance and reflectance
    are textures; and mesh-attr.xml, PLY meshes written here with vertex
    and face colours for mesh_attribute textures."""
    pat = pattern()
    mi.Bitmap(pat).write(os.path.join(d, "pattern.exr"))
    mi.Bitmap(pat).write(os.path.join(d, "pattern.hdr"))
    mi.Bitmap(pat).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8,
                           True).write(os.path.join(d, "pattern.png"))
    mi.Bitmap(pat * 4.0).write(os.path.join(d, "bright.exr"))
    with open(os.path.join(d, "spot-tex.xml"), "w") as f:
        f.write(HEAD + SPOT_TEX + OBJECTS)
    with open(os.path.join(d, "projector.xml"), "w") as f:
        f.write(HEAD + PROJECTOR + OBJECTS)
    with open(os.path.join(d, "projector-flat.xml"), "w") as f:
        f.write(HEAD + PROJECTOR.replace("""		<texture type="bitmap" name="irradiance">
			<string name="filename" value="pattern.exr"/>
		</texture>
""", """		<rgb name="irradiance" value="0.8, 0.6, 0.4"/>
""") + OBJECTS)
    with open(os.path.join(d, "area-tex.xml"), "w") as f:
        f.write(head("0, 3, 7", "0, 1, -0.5", "0, 1, 0", 45) + AREA_TEX)
    with open(os.path.join(d, "tex-more.xml"), "w") as f:
        f.write(HEAD + TEX_MORE)
    ply_grid(os.path.join(d, "ground.ply"), 8, 3.0,
             vcol=lambda x, y: (0.5 + 0.12 * x, 0.45 - 0.1 * y,
                                0.3 + 0.05 * x * y))
    ply_grid(os.path.join(d, "panel.ply"), 3, 0.9,
             fcol=lambda k: ((k % 3) / 2.0, (k % 5) / 4.0, (k % 2) * 0.9))
    ply_grid(os.path.join(d, "lamp.ply"), 2, 0.6,
             vcol=lambda x, y: (1.0 + x, 1.0, 1.0 - y))
    with open(os.path.join(d, "mesh-attr.xml"), "w") as f:
        f.write(HEAD + SKY + ATTRS.replace(
            "LAMP", '<rgb name="radiance" value="4"/>'))
    # Mitsuba 3.9.1's light samples of a mesh_attribute emitter disagree
    # with its own BSDF samples (its direct integrator, light samples
    # only: 0.122 in the mean; BSDF samples only: 0.160, as pm's), so
    # the light with its colours is checked against Mitsuba's BSDF
    # samples alone (8 per pixel sample, their noise being high), direct
    # light only (pm: the path tracer to depth 2).
    with open(os.path.join(d, "mesh-attr-lamp.xml"), "w") as f:
        f.write(HEAD.replace('<integrator type="path"/>',
                             '<integrator type="path">'
                             '<integer name="max_depth" value="2"/>'
                             '</integrator>') +
                ATTRS.replace("LAMP", LAMP_ATTR))
    with open(os.path.join(d, "mesh-attr-lamp-ref.xml"), "w") as f:
        f.write(HEAD.replace('<integrator type="path"/>',
                             '<integrator type="direct">'
                             '<integer name="emitter_samples" value="0"/>'
                             '<integer name="bsdf_samples" value="8"/>'
                             '</integrator>') +
                ATTRS.replace("LAMP", LAMP_ATTR))


if __name__ == "__main__":
    sys.exit(main())
