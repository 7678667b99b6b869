#!/usr/bin/env python3
"""Held-out PSNR with a per-photo colour correction fitted on half of each
photo: for each view that `nerf eval --save DIR` wrote (NAME.png,
NAME_gt.png), an affine map of the render's colour (`A·c + b`, 12 values,
least squares) is fitted on the left half of the photo and the right half
is scored with it, and without it. A model whose colour sits away from a
held-out photo's exposure or white balance gains; the right half's pixels
were not used to fit. Standard library only (8-bit PNG).

    nerf eval RUN/model.nerf --data DIR --split val --save SAVE
    scripts/lib/appearance_half.py SAVE

Prints each view's right-half PSNR without and with the correction, then
both pooled over the views' right halves.
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from region_psnr import read_png  # noqa: E402


def pixels(path):
    """Width, height and RGB rows in [0, 1] of an 8-bit PNG."""
    w, h, ch, rows = read_png(path)
    return w, h, [[tuple(r[x * ch + c] / 255 for c in range(3)) for x in range(w)] for r in rows]


def solve(a, b):
    """x with a·x = b (Gauss-Jordan with partial pivoting)."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for i in range(n):
        p = max(range(i, n), key=lambda r: abs(m[r][i]))
        m[i], m[p] = m[p], m[i]
        for r in range(n):
            if r != i:
                f = m[r][i] / m[i][i]
                m[r] = [x - f * y for x, y in zip(m[r], m[i])]
    return [m[i][n] / m[i][i] for i in range(n)]


def fit(pairs):
    """Per output channel, the least-squares (a_r, a_g, a_b, b) from render to photo."""
    xtx = [[0.0] * 4 for _ in range(4)]
    xty = [[0.0] * 4 for _ in range(3)]
    for x, y in pairs:
        v = (x[0], x[1], x[2], 1.0)
        for i in range(4):
            for j in range(4):
                xtx[i][j] += v[i] * v[j]
            for c in range(3):
                xty[c][i] += v[i] * y[c]
    for i in range(4):
        xtx[i][i] += 1e-6
    return [solve(xtx, xty[c]) for c in range(3)]


def squared_error(pairs, m=None):
    """Summed squared error over the pairs' channels, the render corrected by m (clamped to [0, 1])."""
    s = 0.0
    for x, y in pairs:
        z = [sum(m[c][i] * v for i, v in enumerate((*x, 1.0))) for c in range(3)] if m else x
        s += sum((min(max(z[c], 0.0), 1.0) - y[c]) ** 2 for c in range(3))
    return s


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    d = sys.argv[1]
    total_raw = total_fit = 0.0
    n = 0
    for f in sorted(os.listdir(d)):
        if not f.endswith("_gt.png"):
            continue
        name = f[: -len("_gt.png")]
        w, h, gt = pixels(os.path.join(d, f))
        _, _, r = pixels(os.path.join(d, name + ".png"))
        left = [(r[y][x], gt[y][x]) for y in range(h) for x in range(w // 2)]
        right = [(r[y][x], gt[y][x]) for y in range(h) for x in range(w // 2, w)]
        raw, fitted = squared_error(right), squared_error(right, fit(left))
        k = 3 * len(right)
        print(f"{name}: right half {-10 * math.log10(raw / k):.2f} dB, corrected {-10 * math.log10(fitted / k):.2f} dB")
        total_raw, total_fit, n = total_raw + raw, total_fit + fitted, n + k
    if n == 0:
        sys.exit(f"{d}: no NAME_gt.png beside NAME.png")
    print(f"pooled right halves: {-10 * math.log10(total_raw / n):.2f} dB, corrected {-10 * math.log10(total_fit / n):.2f} dB")


if __name__ == "__main__":
    main()
