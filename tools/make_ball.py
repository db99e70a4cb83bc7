#!/usr/bin/env python3
"""Writes the textured ball of scenes/cornell-gltf.json: ball.obj (a UV sphere of radius 1 with vertex normals and
texture coordinates), ball.mtl (a plastic-like material whose map_Kd is the texture and whose norm is the normal
map), ball.png (a beach ball's six coloured gores with white caps, 256 x 128, equirectangular: u runs around the
equator, v from the top pole) and ball_normal.png (welded seams: a shallow groove where two gores meet and around
each cap, as a tangent-space normal map, +x along u, +y towards the image's top).

Usage: tools/make_ball.py OUT_DIR   (the shipped files: tools/make_ball.py scenes)
"""
import math
import struct
import sys
import zlib
from pathlib import Path

RINGS, SEGMENTS = 24, 48
WIDTH, HEIGHT = 256, 128
GORES = [(230, 40, 40), (250, 200, 30), (40, 110, 220), (250, 250, 245), (40, 170, 80), (240, 120, 30)]


def png(width, height, rows):
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    raw = b"".join(b"\0" + bytes(r) for r in rows)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def texture():
    rows = []
    for y in range(HEIGHT):
        row = []
        polar = (y + 0.5) / HEIGHT  # 0 at the top pole
        for x in range(WIDTH):
            if polar < 0.08 or polar > 0.92:
                colour = (250, 250, 245)  # the caps
            else:
                colour = GORES[int((x + 0.5) / WIDTH * len(GORES)) % len(GORES)]
            row.extend(colour)
        rows.append(row)
    return png(WIDTH, HEIGHT, rows)


def groove_slope(d, half_width=2.5, depth=0.6):
    """The slope dh/dd of a groove h(d) = -depth * cos^2(pi d / (2 half_width)) at texel distance d from its line."""
    if abs(d) >= half_width:
        return 0.0
    a = math.pi / (2 * half_width)
    return depth * 2 * math.cos(a * d) * math.sin(a * d) * a


def normal_map():
    rows = []
    gore = WIDTH / len(GORES)
    caps = (0.08 * HEIGHT, 0.92 * HEIGHT)
    for y in range(HEIGHT):
        row = []
        yc = y + 0.5
        for x in range(WIDTH):
            xc = x + 0.5
            dx = xc - round(xc / gore) * gore  # signed distance to the nearest gore seam, along u
            inside = caps[0] < yc < caps[1]
            hx = groove_slope(dx) if inside else 0.0
            dy = min((yc - c for c in caps), key=abs)
            hy = -groove_slope(dy)  # the map's +y is the image's up, against the rows
            n = (-hx, -hy, 1.0)
            length = math.sqrt(sum(c * c for c in n))
            row.extend(int(round((c / length * 0.5 + 0.5) * 255)) for c in n)
        rows.append(row)
    return png(WIDTH, HEIGHT, rows)


def mesh():
    lines = ["# UV sphere, radius 1, made by tools/make_ball.py", "mtllib ball.mtl"]
    for j in range(RINGS + 1):
        theta = math.pi * j / RINGS
        for i in range(SEGMENTS + 1):  # the seam repeats its column, with u = 1
            phi = 2 * math.pi * i / SEGMENTS
            x, y, z = math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)
            lines.append(f"v {x:.6f} {y:.6f} {z:.6f}")
            lines.append(f"vn {x:.6f} {y:.6f} {z:.6f}")
            lines.append(f"vt {i / SEGMENTS:.6f} {1 - j / RINGS:.6f}")  # OBJ's v grows upwards
    lines.append("usemtl ball")
    for j in range(RINGS):
        for i in range(SEGMENTS):
            a = j * (SEGMENTS + 1) + i + 1
            b, c, d = a + 1, a + SEGMENTS + 2, a + SEGMENTS + 1
            # Counter-clockwise seen from outside; the poles' collapsed triangles are left out.
            if j > 0:
                lines.append(f"f {a}/{a}/{a} {d}/{d}/{d} {b}/{b}/{b}")
            if j < RINGS - 1:
                lines.append(f"f {b}/{b}/{b} {d}/{d}/{d} {c}/{c}/{c}")
    return "\n".join(lines) + "\n"


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    (out / "ball.png").write_bytes(texture())
    (out / "ball_normal.png").write_bytes(normal_map())
    (out / "ball.obj").write_text(mesh())
    (out / "ball.mtl").write_text("# made by tools/make_ball.py\nnewmtl ball\nKd 1 1 1\nKs 0.04 0.04 0.04\nNs 300\n"
                                  "map_Kd ball.png\nnorm ball_normal.png\n")


if __name__ == "__main__":
    main()
