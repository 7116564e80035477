#!/usr/bin/env python3
"""frames_maps.py: the bitmaps of tests/mitsuba/frames.xml.

    frames_maps.py DIR

Writes DIR/normals.png, a tangent-space normal map (normals tilted along
u by a sine in u and along v by a sine in v, encoded as (n + 1) / 2 in
8 bits, as Mitsuba's normalmap reads them), and DIR/heights.png, a
height field for bumpmap (a product of sines, grey).  Both are 32 x 32
and computed, not random; written with zlib alone.
"""
import math
import os
import struct
import sys
import zlib

N = 32


def normal(x, y):
    u, v = (x + 0.5) / N, (y + 0.5) / N
    nx = 0.6 * math.sin(2 * math.pi * 2 * u)
    ny = 0.4 * math.cos(2 * math.pi * 3 * v)
    s = 1.0 / math.sqrt(nx * nx + ny * ny + 1.0)
    return tuple(int(round(255 * (c * s + 1) / 2)) for c in (nx, ny, 1.0))


def height(x, y):
    u, v = (x + 0.5) / N, (y + 0.5) / N
    h = 0.5 + 0.5 * math.sin(2 * math.pi * 3 * u) * math.sin(2 * math.pi * 2 * v)
    g = int(round(255 * h))
    return (g, g, g)


def chunk(kind, data):
    c = struct.pack(">I", len(data)) + kind + data
    return c + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)


def write(path, pixel):
    rows = b"".join(b"\0" + bytes(c for x in range(N) for c in pixel(x, y))
                    for y in range(N))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n"
                + chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(rows, 9))
                + chunk(b"IEND", b""))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: frames_maps.py DIR")
    os.makedirs(sys.argv[1], exist_ok=True)
    write(os.path.join(sys.argv[1], "normals.png"), normal)
    write(os.path.join(sys.argv[1], "heights.png"), height)


if __name__ == "__main__":
    main()
