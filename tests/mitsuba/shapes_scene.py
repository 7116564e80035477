#!/usr/bin/env python3
"""shapes_scene.py: writes the scenes that check pm's cylinder, serialized,
shapegroup, instance, orthographic and thinlens plugins against Mitsuba 3.

    shapes_scene.py DIR

DIR receives shapes.serialized (two meshes, written here from the format
Mitsuba documents: a smooth sphere with its normals and uv in single
precision, then an octahedron in double precision without normals, read
with shape_index 1 and face_normals) and two scenes that differ only in the
sensor: shapes-ortho.xml (orthographic, its film sized by to_world's scale)
and shapes-thinlens.xml (a thin lens focused on the cylinder).  Both hold a
diffuse box, a diffuse cylinder given by p0, p1 and radius, a thin emitting
cylinder (a tube light: area sampling of the cylinder) under a ceiling
light, the two serialized meshes, and two instances of a shapegroup (a
cylinder capped by a sphere).  The octahedron is shaded with its face
normals: smooth-shaded (vertex normals computed from faces at 90 degrees to
each other), pm's photon mode comes out 2-4% bright over it, 9 of 768
blocks beyond 4 sigma (1M photons, no image-space cache, as compare.sh
renders), while path tracing agrees there; that is photon mapping's, not
what this scene is for.  Only standard-library Python.
"""

import math
import os
import struct
import sys
import zlib


def mesh(pos, idx, nrm=None, uv=None, dbl=False, name=b"mesh"):
    """One mesh of a version-4 file: the plain header, then the zlib
    stream of flags, name, counts and arrays."""
    flags = (0x1 if nrm else 0) | (0x2 if uv else 0) | \
        (0x2000 if dbl else 0x1000)
    f = "d" if dbl else "f"
    raw = struct.pack("<I", flags) + name + b"\0"
    raw += struct.pack("<QQ", len(pos) // 3, len(idx) // 3)
    for arr in (pos, nrm, uv):
        if arr:
            raw += struct.pack("<%d%s" % (len(arr), f), *arr)
    raw += struct.pack("<%dI" % len(idx), *idx)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(raw, 9)


def serialized(meshes):
    out, offsets = b"", []
    for m in meshes:
        offsets.append(len(out))
        out += m
    for o in offsets:
        out += struct.pack("<Q", o)
    return out + struct.pack("<I", len(meshes))


def sphere(rings=24, segments=48):
    pos, nrm, uv, idx = [], [], [], []
    for i in range(rings + 1):
        th = math.pi * i / rings
        for j in range(segments + 1):
            ph = 2 * math.pi * j / segments
            p = (math.sin(th) * math.cos(ph), math.cos(th),
                 math.sin(th) * math.sin(ph))
            pos += p
            nrm += p
            uv += (j / segments, i / rings)
    w = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b = i * w + j, (i + 1) * w + j
            if i > 0:
                idx += (a, a + 1, b)
            if i < rings - 1:
                idx += (a + 1, b + 1, b)
    return pos, nrm, uv, idx


def octahedron():
    pos = [1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1]
    idx = []
    for x in (0, 1):
        for y in (2, 3):
            for z in (4, 5):
                tri = [x, y, z]
                # counter-clockwise seen from outside
                sgn = (1 if x == 0 else -1) * (1 if y == 2 else -1) * \
                    (1 if z == 4 else -1)
                idx += tri if sgn > 0 else [x, z, y]
    return pos, idx


SENSORS = {
    "ortho": """	<sensor type="orthographic">
		<float name="near_clip" value="0.1"/>
		<transform name="to_world">
			<scale x="1.3" y="1.3"/>
			<lookat origin="0.3, 2.6, 4" target="0, 0.9, 0" up="0, 1, 0"/>
		</transform>""",
    "thinlens": """	<sensor type="thinlens">
		<float name="fov" value="42"/>
		<float name="aperture_radius" value="0.08"/>
		<float name="focus_distance" value="3.6"/>
		<transform name="to_world">
			<lookat origin="0, 1.1, 4.3" target="0, 0.8, 0" up="0, 1, 0"/>
		</transform>""",
}

SCENE = """<!-- written by tests/mitsuba/shapes_scene.py -->
<scene version="3.0.0">
	<default name="spp" value="64"/>
	<default name="res" value="256"/>

	<integrator type="path"/>

%(sensor)s
		<sampler type="independent">
			<integer name="sample_count" value="$spp"/>
		</sampler>
		<film type="hdrfilm">
			<integer name="width" value="$res"/>
			<integer name="height" value="$res"/>
			<rfilter type="box"/>
		</film>
	</sensor>

	<bsdf type="diffuse" id="white">
		<rgb name="reflectance" value="0.7, 0.7, 0.7"/>
	</bsdf>
	<bsdf type="diffuse" id="red">
		<rgb name="reflectance" value="0.63, 0.065, 0.05"/>
	</bsdf>
	<bsdf type="diffuse" id="green">
		<rgb name="reflectance" value="0.14, 0.45, 0.091"/>
	</bsdf>
	<bsdf type="diffuse" id="blue">
		<rgb name="reflectance" value="0.1, 0.2, 0.6"/>
	</bsdf>

	<shape type="rectangle">
		<transform name="to_world">
			<rotate x="1" angle="-90"/>
		</transform>
		<ref id="white"/>
	</shape>
	<shape type="rectangle">
		<transform name="to_world">
			<rotate x="1" angle="90"/>
			<translate y="2"/>
		</transform>
		<ref id="white"/>
	</shape>
	<shape type="rectangle">
		<transform name="to_world">
			<translate y="1" z="-1"/>
		</transform>
		<ref id="white"/>
	</shape>
	<shape type="rectangle">
		<transform name="to_world">
			<rotate y="1" angle="90"/>
			<translate x="-1" y="1"/>
		</transform>
		<ref id="red"/>
	</shape>
	<shape type="rectangle">
		<transform name="to_world">
			<rotate y="1" angle="-90"/>
			<translate x="1" y="1"/>
		</transform>
		<ref id="green"/>
	</shape>

	<!-- an open cylinder, leaning: its inside shows from above -->
	<shape type="cylinder">
		<point name="p0" x="-0.45" y="0" z="-0.2"/>
		<point name="p1" x="-0.35" y="0.9" z="-0.35"/>
		<float name="radius" value="0.3"/>
		<ref id="blue"/>
	</shape>

	<!-- a tube light along the back wall -->
	<shape type="cylinder">
		<point name="p0" x="-0.8" y="1.6" z="-0.85"/>
		<point name="p1" x="0.8" y="1.6" z="-0.85"/>
		<float name="radius" value="0.03"/>
		<emitter type="area">
			<rgb name="radiance" value="4, 6, 9"/>
		</emitter>
	</shape>

	<!-- the serialized meshes -->
	<shape type="serialized">
		<string name="filename" value="shapes.serialized"/>
		<transform name="to_world">
			<scale value="0.3"/>
			<translate x="0.45" y="0.3" z="0.3"/>
		</transform>
		<ref id="white"/>
	</shape>
	<shape type="serialized">
		<string name="filename" value="shapes.serialized"/>
		<integer name="shape_index" value="1"/>
		<boolean name="face_normals" value="true"/>
		<transform name="to_world">
			<scale value="0.25"/>
			<rotate y="1" angle="30"/>
			<translate x="0.1" y="0.3" z="-0.65"/>
		</transform>
		<ref id="white"/>
	</shape>

	<!-- a group of a capped post, drawn twice through instances -->
	<shape type="shapegroup" id="post">
		<shape type="cylinder">
			<point name="p0" x="0" y="0.02" z="0"/>
			<point name="p1" x="0" y="0.22" z="0"/>
			<float name="radius" value="0.08"/>
			<ref id="red"/>
		</shape>
		<shape type="sphere">
			<point name="center" x="0" y="0.3" z="0"/>
			<float name="radius" value="0.07"/>
			<ref id="white"/>
		</shape>
	</shape>
	<shape type="instance">
		<ref id="post"/>
		<transform name="to_world">
			<translate x="-0.55" z="0.55"/>
		</transform>
	</shape>
	<shape type="instance">
		<ref id="post"/>
		<transform name="to_world">
			<scale value="1.3"/>
			<rotate x="1" angle="-20"/>
			<translate x="0.65" y="0.05" z="-0.35"/>
		</transform>
	</shape>

	<shape type="rectangle">
		<transform name="to_world">
			<scale x="0.25" y="0.2"/>
			<rotate x="1" angle="90"/>
			<translate y="1.99"/>
		</transform>
		<bsdf type="diffuse">
			<rgb name="reflectance" value="0.78, 0.78, 0.78"/>
		</bsdf>
		<emitter type="area">
			<rgb name="radiance" value="17, 12, 4"/>
		</emitter>
	</shape>
</scene>
"""


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: shapes_scene.py DIR")
    d = sys.argv[1]
    os.makedirs(d, exist_ok=True)
    pos, nrm, uv, idx = sphere()
    opos, oidx = octahedron()
    with open(os.path.join(d, "shapes.serialized"), "wb") as f:
        f.write(serialized([mesh(pos, idx, nrm=nrm, uv=uv, name=b"sphere"),
                            mesh(opos, oidx, dbl=True, name=b"octa")]))
    for name, sensor in SENSORS.items():
        with open(os.path.join(d, "shapes-%s.xml" % name), "w") as f:
            f.write(SCENE % {"sensor": sensor})


if __name__ == "__main__":
    main()
