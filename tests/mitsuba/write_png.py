#!/usr/bin/env python3
"""write_png.py: the bitmap of tests/mitsuba/textures.xml.

    write_png.py OUT.png

An 8 x 6 RGB image of 8-bit samples that differ from texel to texel
(a fixed pattern, no randomness), written with zlib alone so that the
test needs nothing beyond Python.
"""
import struct
import sys
import zlib

W, H = 8, 6


def pixel(x, y):
    return ((37 * x + 11 * y + 40) % 256,
            (23 * y + 9 * x * y + 90) % 256,
            (200 - 19 * x + 7 * y) % 256)


def chunk(kind, data):
    c = struct.pack(">I", len(data)) + kind + data
    return c + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)


def main():
    rows = b"".join(b"\0" + bytes(v for x in range(W) for v in pixel(x, y))
                    for y in range(H))
    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(rows, 9))
           + chunk(b"IEND", b""))
    with open(sys.argv[1], "wb") as f:
        f.write(png)


if __name__ == "__main__":
    main()
