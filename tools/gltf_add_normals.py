#!/usr/bin/env python3
"""Adds smooth vertex normals (NORMAL) to meshes of a binary glTF (.glb) file that have none.

Each vertex gets the area-weighted average of the normals of the triangles that use it (the cross product of two
edges is twice the area times the unit normal, so summing the raw cross products weights by area), which is how
modelling tools make a mesh smooth. Vertices that several triangles index share one normal; a mesh whose
triangles are meant to stay faceted (a cut gem) keeps its own look when it is left out of --mesh.

Usage: tools/gltf_add_normals.py IN.glb OUT.glb --mesh 0 [--mesh 2 ...]
Used for scenes/torus-and-gem.glb (the torus, mesh 0).
"""
import argparse
import json
import struct
import sys

COMPONENT = {5121: ("B", 1), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(doc, binary, index):
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    fmt, size = COMPONENT[a["componentType"]]
    n = WIDTH[a["type"]]
    stride = view.get("byteStride", size * n)
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return [struct.unpack_from("<" + fmt * n, binary, start + i * stride) for i in range(a["count"])]


def vertex_normals(positions, triangles):
    sums = [[0.0, 0.0, 0.0] for _ in positions]
    for a, b, c in triangles:
        pa, pb, pc = positions[a], positions[b], positions[c]
        e1 = [pb[k] - pa[k] for k in range(3)]
        e2 = [pc[k] - pa[k] for k in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        for v in (a, b, c):
            for k in range(3):
                sums[v][k] += n[k]
    out = []
    for s in sums:
        length = (s[0] ** 2 + s[1] ** 2 + s[2] ** 2) ** 0.5
        out.append([x / length for x in s] if length > 0 else [0.0, 0.0, 0.0])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--mesh", type=int, action="append", required=True, help="index of a mesh to smooth")
    args = parser.parse_args()
    data = open(args.input, "rb").read()
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        sys.exit(f"{args.input}: not a glTF 2.0 binary file")
    json_len, json_type = struct.unpack_from("<I4s", data, 12)
    doc = json.loads(data[20:20 + json_len])
    bin_start = 20 + json_len
    bin_len, bin_type = struct.unpack_from("<I4s", data, bin_start)
    if json_type != b"JSON" or bin_type != b"BIN\0":
        sys.exit(f"{args.input}: expected a JSON chunk then a BIN chunk")
    binary = bytearray(data[bin_start + 8:bin_start + 8 + bin_len])
    for m in args.mesh:
        for prim in doc["meshes"][m]["primitives"]:
            if "NORMAL" in prim["attributes"]:
                continue
            positions = read_accessor(doc, binary, prim["attributes"]["POSITION"])
            if "indices" in prim:
                flat = [i[0] for i in read_accessor(doc, binary, prim["indices"])]
            else:
                flat = list(range(len(positions)))
            triangles = [flat[i:i + 3] for i in range(0, len(flat) - 2, 3)]
            normals = vertex_normals(positions, triangles)
            while len(binary) % 4:
                binary.append(0)
            offset = len(binary)
            for n in normals:
                binary += struct.pack("<3f", *n)
            doc["bufferViews"].append({"buffer": 0, "byteOffset": offset, "byteLength": 12 * len(normals)})
            doc["accessors"].append({"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126,
                                     "count": len(normals), "type": "VEC3"})
            prim["attributes"]["NORMAL"] = len(doc["accessors"]) - 1
    while len(binary) % 4:
        binary.append(0)
    doc["buffers"][0]["byteLength"] = len(binary)
    text = json.dumps(doc, separators=(",", ":")).encode()
    while len(text) % 4:
        text += b" "
    total = 12 + 8 + len(text) + 8 + len(binary)
    out = struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON") + text
    out += struct.pack("<I4s", len(binary), b"BIN\0") + bytes(binary)
    open(args.output, "wb").write(out)


if __name__ == "__main__":
    main()
