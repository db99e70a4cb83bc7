#!/usr/bin/env python3
"""Denoise a `pathtracer render --exr` file with Intel Open Image Denoise, for side-by-side measurements only
(docs/denoising.md: "Beside Intel Open Image Denoise"); OIDN is never a dependency of the product.

    python3 -m venv /tmp/oidn && /tmp/oidn/bin/pip install pyoidn numpy OpenEXR
    /tmp/oidn/bin/python tools/oidn_compare.py render.exr oidn.pfm
    build/app/pathtracer compare oidn.pfm REFERENCE.pfm --blocks 16

Reads the beauty (RGB), albedo and normal layers, runs OIDN's RT filter (hdr, quality "high") once to warm up
and three times timed, prints the times and writes the result as a little-endian PFM (rows bottom to top).
"""
import sys
import time

import numpy as np
import OpenEXR
import pyoidn


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: oidn_compare.py RENDER.exr OUT.pfm")
    src, out = sys.argv[1], sys.argv[2]
    channels = OpenEXR.File(src).channels()
    for needed in ("RGB", "albedo", "normal.X"):
        if needed not in channels:
            sys.exit(f"{src}: no '{needed}' layer (render with --exr and --aov albedo,normal)")
    color = np.ascontiguousarray(channels["RGB"].pixels, dtype=np.float32)
    albedo = np.ascontiguousarray(channels["albedo"].pixels, dtype=np.float32)
    normal = np.ascontiguousarray(np.stack([channels["normal." + a].pixels for a in "XYZ"], axis=-1), dtype=np.float32)
    pyoidn.denoise(color, albedo, normal, hdr=True)  # warm-up: loads the network's weights
    times = []
    for _ in range(3):
        start = time.perf_counter()
        denoised = pyoidn.denoise(color, albedo, normal, hdr=True)
        times.append(time.perf_counter() - start)
    print("oidn seconds:", " ".join(f"{t:.3f}" for t in times), f"(median {sorted(times)[1]:.3f})")
    height, width, _ = denoised.shape
    with open(out, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (width, height))
        f.write(np.ascontiguousarray(denoised[::-1], dtype="<f4").tobytes())


if __name__ == "__main__":
    main()
