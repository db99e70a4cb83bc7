#!/usr/bin/env python3
"""Time per sample against triangle count (docs/performance.md, "Meshes").

Writes a lat-long tessellated sphere of about N triangles for N = 10^2 ... 10^6 (a procedural mesh: every
triangle is visible to some rays, as in a scanned model), puts it in the Cornell box of scenes/cornell.json and
renders it with `pathtracer render`, reporting samples per second and the load time (parse, mesh, BVH build).
A benchmark, not a test: it prints figures and never fails on them.

usage: tools/mesh_scaling.py [--pathtracer build/app/pathtracer] [--threads 2] [--spp 16] [--size 128]
"""
import argparse, json, math, os, re, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def sphere_obj(path, triangles):
    rings = max(2, int(math.sqrt(triangles / 4)))
    segments = 2 * rings
    with open(path, "w") as f:
        f.write("v 0 1 0\nv 0 -1 0\n")
        for i in range(1, rings):
            th = math.pi * i / rings
            for j in range(segments):
                ph = 2 * math.pi * j / segments
                f.write(f"v {math.sin(th) * math.cos(ph):.7f} {math.cos(th):.7f} {math.sin(th) * math.sin(ph):.7f}\n")
        ring = lambda i, j: 3 + (i - 1) * segments + j % segments  # 1-based OBJ index of ring i ≥ 1
        count = 0
        for j in range(segments):
            f.write(f"f 1 {ring(1, j + 1)} {ring(1, j)}\n")
            f.write(f"f 2 {ring(rings - 1, j)} {ring(rings - 1, j + 1)}\n")
            count += 2
        for i in range(1, rings - 1):
            for j in range(segments):
                f.write(f"f {ring(i, j)} {ring(i, j + 1)} {ring(i + 1, j)}\n")
                f.write(f"f {ring(i, j + 1)} {ring(i + 1, j + 1)} {ring(i + 1, j)}\n")
                count += 2
    return count


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pathtracer", default=os.path.join(ROOT, "build/app/pathtracer"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--size", type=int, default=128)
    a = ap.parse_args()
    with open(os.path.join(ROOT, "scenes/cornell.json")) as f:
        base = f.read()
    print("| triangles | load s | render s | Msamples/s | Mrays/s |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for n in [10**2, 10**3, 10**4, 10**5, 10**6]:
            count = sphere_obj(os.path.join(d, "m.obj"), n)
            mesh = ('{"type": "mesh", "file": "m.obj", "material": "white", "transform": '
                    '{"scale": 150, "translate": [278, 200, 280]}},')
            with open(os.path.join(d, "s.json"), "w") as f:
                f.write(base.replace('"shapes": [', '"shapes": [\n    ' + mesh, 1))
            t0 = time.time()
            r = subprocess.run([a.pathtracer, "render", "--scene", os.path.join(d, "s.json"), "--spp", str(a.spp),
                                "--width", str(a.size), "--height", str(a.size), "--threads", str(a.threads),
                                "--pfm", os.path.join(d, "out.pfm"), "-q"], capture_output=True, text=True)
            wall = time.time() - t0
            m = re.search(r"in ([0-9.]+) s, ([0-9.]+) Msamples/s, ([0-9.]+) Mrays/s", r.stdout + r.stderr)
            if r.returncode != 0 or not m:
                print(r.stdout, r.stderr, file=sys.stderr)
                return 1
            render_s = float(m.group(1))
            print(f"| {count} | {wall - render_s:.2f} | {render_s:.2f} | {m.group(2)} | {m.group(3)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
