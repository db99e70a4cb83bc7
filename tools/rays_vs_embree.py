#!/usr/bin/env python3
"""The project and Intel Embree on exactly the same rays (docs/performance.md, "Ray files").

For each scene: `pathtracer bench rays --export-tris` writes the polygons the tracer holds (meshes included) as
the peers' triangle file; Embree's `embree_rays` (../shared/peers, built by its build.sh) records 2^20 rays of
its recipe into a ray file, `pathtracer bench rays --record` records 2^20 of the project's own path rays; then
each file is replayed by Embree (triangles, and quads where the scene has them) and by the project (one ray
at a time, and in packets where the scene is on brute force), one thread,
median of 5 replays each, the systems alternating. Prints Mrays/s, hit counts and ratios project / Embree.
A benchmark, not a test: it prints figures and fails only when a tool fails or hit counts differ in more than
10^-5 of the rays. (They may differ in a few: the tracer holds geometry camera-relative, so a file in world
coordinates is rounded once more on the way out and back; a ray leaving a surface can then start 10^-5 behind
it in one system and in front of it in the other.)

usage: tools/rays_vs_embree.py [--pathtracer build/app/pathtracer] [--out rays-out] [--count 1048576]
                               [SCENE ...]     (default: cornell scenes/cornell-bunny.json)
"""
import argparse, json, os, subprocess, sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS = os.path.join(ROOT, "..", "shared", "peers")


def run_json(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pathtracer", default=os.path.join(ROOT, "build", "app", "pathtracer"))
    ap.add_argument("--out", default="rays-out")
    ap.add_argument("--count", type=int, default=1 << 20)
    ap.add_argument("scenes", nargs="*", default=["cornell", os.path.join(ROOT, "scenes", "cornell-bunny.json")])
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    emb = subprocess.run([os.path.join(PEERS, "build.sh")], capture_output=True, text=True)
    if emb.returncode != 0:
        sys.exit("embree_rays did not build (../shared/peers/build.sh):\n" + emb.stderr)
    embree = emb.stdout.strip().splitlines()[-1]
    pt = [a.pathtracer, "bench", "rays", "--json", "--threads", "1"]
    print("%-14s %-8s %-22s %8s %8s %8s %9s" % ("scene", "rays", "system", "closest", "shadow", "sh.half", "hits"))
    mismatch = False
    for scene in a.scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        tris, emb_rays, own_rays = (os.path.join(a.out, name + s) for s in (".tris", "-embree.rays", "-project.rays"))
        for f in (emb_rays, own_rays):
            if os.path.exists(f):
                os.remove(f)
        r = subprocess.run([a.pathtracer, "bench", "rays", "--scene", scene, "--record", own_rays, "--count",
                            str(a.count), "--export-tris", tris], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(r.stderr)
        made = run_json([embree, "--tris", tris, "--write-rays", emb_rays, "--count", str(a.count), "--json"])
        for label, rays in (("embree", emb_rays), ("project", own_rays)):
            embree_rows = [("triangles", run_json([embree, "--tris", tris, "--rays", rays, "--json"]))]
            project_rows = [("project", run_json(pt + ["--scene", scene, "--rays", rays]))]
            if project_rows[0][1]["polygon_accel"] == "brute-force SIMD":  # the packet kernels serve these scenes
                project_rows.append(("project packets", run_json(pt + ["--scene", scene, "--rays", rays, "--packets"])))
            if made["triangles"] <= 64:  # the Cornell scenes: quads as Embree's own primitive, its best case
                embree_rows.append(("quads", run_json([embree, "--tris", tris, "--rays", rays, "--quads", "--json"])))
            for system, j in [("Embree " + k, j) for k, j in embree_rows] + project_rows:
                print("%-14s %-8s %-22s %8.2f %8.2f %8.2f %9d" % (name, label, system, j["closest_mrays_s"],
                      j["shadow_mrays_s"], j["shadow_half_mrays_s"], j["closest_hits"]))
            for mine, p in project_rows:
                for kind, j in embree_rows:
                    print("%-14s %-8s ratio %s / %s %8.2f %8.2f %8.2f" % (name, label, mine, kind,
                          p["closest_mrays_s"] / j["closest_mrays_s"], p["shadow_mrays_s"] / j["shadow_mrays_s"],
                          p["shadow_half_mrays_s"] / j["shadow_half_mrays_s"]))
                    if (j["closest_hits"], j["occluded_half"]) != (p["closest_hits"], p["occluded_half"]):
                        diff = abs(j["closest_hits"] - p["closest_hits"]) + abs(j["occluded_half"] - p["occluded_half"])
                        mismatch = mismatch or diff > 1e-5 * p["rays"]
                        print("  hit counts differ: Embree %d / %d, %s %d / %d" % (j["closest_hits"],
                              j["occluded_half"], mine, p["closest_hits"], p["occluded_half"]))
    sys.exit(1 if mismatch else 0)


main()
