#!/usr/bin/env python3
"""Writes a .glb whose one mesh (a bumpy sphere of about TRIANGLES triangles, with vertex normals) is shown by
COPIES nodes on a square grid, each turned differently: the file that measures instancing (docs/performance.md,
"Instances"). With COPIES = 1 the mesh is placed as plain triangles (a mesh shown once is not instanced); with
more, it is stored once and placed by that many instances.

With --distinct, each node shows a mesh of its own (all reading the same buffers), so nothing is instanced: the
same triangles placed one by one, to compare with.

Usage: tools/make_instances.py [--distinct] OUT.glb TRIANGLES COPIES
"""
import json
import math
import struct
import sys


def bumpy_sphere(triangles):
    """Positions, normals and indices of a UV sphere with about `triangles` triangles and gentle bumps."""
    n = max(4, int(math.sqrt(triangles / 2)))
    rings, segments = n, n
    pos, nor = [], []
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            d = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            radius = 1 + 0.05 * math.sin(7 * th) * math.sin(5 * ph)
            pos.append(tuple(radius * c for c in d))
            nor.append(d)  # the unbumped normal: smooth enough for shading
    idx = []
    row = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b, c, d = r * row + s, (r + 1) * row + s, (r + 1) * row + s + 1, r * row + s + 1
            if r != 0:
                idx += [a, c, b]
            if r != rings - 1:
                idx += [a, d, c]
    return pos, nor, idx


def main():
    args = sys.argv[1:]
    distinct = "--distinct" in args
    if distinct:
        args.remove("--distinct")
    out, triangles, copies = args[0], int(args[1]), int(args[2])
    pos, nor, idx = bumpy_sphere(triangles)
    blob = b"".join(struct.pack("<3f", *p) for p in pos)
    blob += b"".join(struct.pack("<3f", *v) for v in nor)
    blob += struct.pack("<%dI" % len(idx), *idx)
    vbytes = 12 * len(pos)
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    side = math.ceil(math.sqrt(copies))
    nodes = []
    for k in range(copies):
        angle = 0.7 * k
        nodes.append({"mesh": k if distinct else 0, "translation": [2.5 * (k % side), 0.0, -2.5 * (k // side)],
                      "rotation": [0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)]})
    doc = {
        "asset": {"version": "2.0", "generator": "tools/make_instances.py"},
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": vbytes},
                        {"buffer": 0, "byteOffset": vbytes, "byteLength": vbytes},
                        {"buffer": 0, "byteOffset": 2 * vbytes, "byteLength": 4 * len(idx)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
                      {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC3"},
                      {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"}],
        "materials": [{"name": "clay", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.5, 1],
                                                                "metallicFactor": 0, "roughnessFactor": 0.6}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}]
                  * (copies if distinct else 1),
        "nodes": nodes,
        "scenes": [{"nodes": list(range(copies))}],
        "scene": 0,
    }
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    with open(out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    print("%s: %d triangles x %d copies" % (out, len(idx) // 3, copies))


if __name__ == "__main__":
    main()
