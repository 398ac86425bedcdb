#!/usr/bin/env python3
"""Writes tests/data/serialized/two_shapes.serialized, a small Mitsuba
serialized mesh file (format version 4) for the reader's tests and as a seed
for the fuzz_serialized target.

Shape 0, "tetrahedron": 4 vertices with unit normals, 4 outward-facing
triangles, single precision. Shape 1, "quad": the square [-1, 1]^2 at z = 0
as 2 triangles, with uvs, double precision.

The layout is the one Mitsuba 3's serialized shape plugin reads: Mitsuba 3.9.1
loads this file (shape_index 0 and 1) to the same vertices, faces, normals and
uvs (checked when it was written). Per shape a uint16 format id 0x041C
and uint16 version 4, then a zlib stream of uint32 flags, the NUL-terminated
name, uint64 vertex and triangle counts, positions, normals and uvs as flagged,
and uint32 indices; at the end each shape's uint64 byte offset and the uint32
shape count. Everything little endian. Standard library only:

    python3 tools/write_serialized.py [output path]
"""

import math
import os
import struct
import sys
import zlib

FORMAT_ID = 0x041C
VERSION = 4
HAS_NORMALS = 0x0001
HAS_UVS = 0x0002
SINGLE_PRECISION = 0x1000
DOUBLE_PRECISION = 0x2000


def shape_stream(name, flags, positions, triangles, normals=(), uvs=()):
    """The compressed stream of one shape."""
    real = "<d" if flags & DOUBLE_PRECISION else "<f"
    out = struct.pack("<I", flags) + name.encode("utf-8") + b"\0"
    out += struct.pack("<QQ", len(positions), len(triangles))
    for array in (positions, normals, uvs):
        for vector in array:
            out += b"".join(struct.pack(real, x) for x in vector)
    for triangle in triangles:
        out += struct.pack("<3I", *triangle)
    return zlib.compress(out, 9)


def serialized_file(streams):
    """The streams, each behind its shape header, then the offset table and the count."""
    out = b""
    offsets = []
    for stream in streams:
        offsets.append(len(out))
        out += struct.pack("<HH", FORMAT_ID, VERSION) + stream
    return out + b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(streams))


def two_shapes():
    corners = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
    s = 1 / math.sqrt(3)
    tetrahedron = shape_stream("tetrahedron", SINGLE_PRECISION | HAS_NORMALS, corners,
                               [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)],
                               normals=[(x * s, y * s, z * s) for x, y, z in corners])
    quad = shape_stream("quad", DOUBLE_PRECISION | HAS_UVS, [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
                        [(0, 1, 2), (0, 2, 3)], uvs=[(0, 0), (1, 0), (1, 1), (0, 1)])
    return serialized_file([tetrahedron, quad])


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "tests", "data", "serialized",
                                                              "two_shapes.serialized")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "wb") as f:
        f.write(two_shapes())


if __name__ == "__main__":
    main()
