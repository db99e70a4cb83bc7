#!/usr/bin/env python3
"""Block-average a 3-channel PFM by an integer factor (box filter), keeping PFM conventions.

Used once to derive tests/data/cornell_128_cycles.pfm from ../shared/reference/cornell_512_cycles.pfm
(factor 4), so the tests carry the independent reference inside the project:
    python3 tools/downsample_pfm.py ../shared/reference/cornell_512_cycles.pfm tests/data/cornell_128_cycles.pfm 4
Block averaging preserves the image mean exactly (up to rounding) and the mean of every aligned block.
"""
import array
import sys


def read_pfm(path):
    with open(path, "rb") as f:
        data = f.read()
    parts = data.split(maxsplit=4)  # magic, width, height, scale, rest
    header_end = 0
    for _ in range(4):  # walk past four whitespace-separated tokens and the single separator byte
        while data[header_end:header_end + 1].isspace():
            header_end += 1
        while not data[header_end:header_end + 1].isspace():
            header_end += 1
    header_end += 1
    magic, w, h, scale = parts[0], int(parts[1]), int(parts[2]), float(parts[3])
    assert magic == b"PF", "only 3-channel PFM is supported"
    px = array.array("f")
    px.frombytes(data[header_end:header_end + 12 * w * h])
    if (scale < 0) != (sys.byteorder == "little"):
        px.byteswap()
    return w, h, px  # rows bottom to top, as stored


def main():
    src, dst, factor = sys.argv[1], sys.argv[2], int(sys.argv[3])
    w, h, px = read_pfm(src)
    assert w % factor == 0 and h % factor == 0
    ow, oh = w // factor, h // factor
    out = array.array("f", [0.0] * (3 * ow * oh))
    for y in range(h):
        for x in range(w):
            o = 3 * ((y // factor) * ow + x // factor)
            i = 3 * (y * w + x)
            for c in range(3):
                out[o + c] += px[i + c]
    inv = 1.0 / (factor * factor)
    for k in range(len(out)):
        out[k] *= inv
    if sys.byteorder != "little":
        out.byteswap()
    with open(dst, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (ow, oh))
        f.write(out.tobytes())


if __name__ == "__main__":
    main()
