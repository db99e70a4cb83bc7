#!/usr/bin/env python3
"""The include arrows between tracer/ folders, and those that run up the layering.

Usage: tools/include_graph.py [TRACER_DIR]   (default: tracer next to this script's folder)

An arrow A -> B (n) means n #include "B/..." lines in files of tracer/A. The layering, bottom first, is LAYERS
below (a folder may include its own layer and those under it); an arrow to a higher layer is listed as "up".
Exit status 0 whatever it finds: a report, not a gate (the closing notes of issue 38 quote it).
"""
import collections
import os
import re
import sys

# Bottom first; folders on one line share a layer.
LAYERS = [
    ["core"],
    ["sampling"],
    ["geometry", "materials", "film"],
    ["io"],
    ["lights"],
    ["scene"],
    ["integrators"],
    ["denoise"],
    ["render"],
]
RANK = {folder: i for i, layer in enumerate(LAYERS) for folder in layer}


def arrows(root):
    found = collections.Counter()
    for folder in sorted(os.listdir(root)):
        path = os.path.join(root, folder)
        if not os.path.isdir(path):
            continue
        for name in sorted(os.listdir(path)):
            if not name.endswith((".h", ".cpp")):
                continue
            with open(os.path.join(path, name), encoding="utf-8") as f:
                for line in f:
                    m = re.match(r'\s*#include\s+"([a-z_]+)/', line)
                    if m and m.group(1) != folder:
                        found[(folder, m.group(1))] += 1
    return found


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "tracer")
    found = arrows(root)
    up = []
    for (a, b), n in sorted(found.items()):
        ra, rb = RANK.get(a), RANK.get(b)
        mark = ""
        if ra is None or rb is None:
            mark = "  (folder not in LAYERS)"
        elif rb > ra:
            mark = "  up"
            up.append((a, b, n))
        print(f"{a} -> {b} ({n}){mark}")
    print(f"{len(found)} arrows, {len(up)} up: " + (", ".join(f"{a} -> {b}" for a, b, _ in up) or "none"))


if __name__ == "__main__":
    main()
