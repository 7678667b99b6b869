#!/usr/bin/env python3
"""PSNR of renders over the object's pixels and over the rest, for the
built-in scene's room capture: the object's pixels are those that are not
black in the same view of the scene on black (whose cameras are the room
capture's). Reads the PNGs that `nerf eval --save DIR` writes (NAME.png,
NAME_gt.png); standard library only (8-bit PNG, any filter).

    nerf scene --out S --size 64
    nerf eval ROOM/model.nerf --data S/room --split val --save ROOM_SAVE
    nerf eval OBJ/model.nerf --data S/colmap --scene object --split val --save OBJ_SAVE
    scripts/lib/region_psnr.py ROOM_SAVE OBJ_SAVE

Prints each view's two PSNRs and pixel counts, then the pooled PSNR of
each region and its share of the squared error, and of every pixel; then
the object's pixels split in two: its silhouette (an object pixel with a
pixel of the rest among its eight neighbours, where the render blends the
object with what lies behind it) and its interior (the others).
"""

import math
import os
import struct
import sys
import zlib

# a pixel is the object's if a channel of the scene on black exceeds this (of
# 255): the object's pixels darker than that in every channel count as the rest
OBJECT_LEVEL = 12


def read_png(path):
    """Width, height, channels and rows (bytearrays) of an 8-bit PNG."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    i, idat = 8, b""
    while i < len(data):
        (n,) = struct.unpack(">I", data[i : i + 4])
        kind, body = data[i + 4 : i + 8], data[i + 8 : i + 8 + n]
        i += 12 + n
        if kind == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
        elif kind == b"IDAT":
            idat += body
    if depth != 8:
        sys.exit(f"{path}: {depth}-bit PNG (8-bit expected)")
    ch = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
    raw, stride, rows = zlib.decompress(idat), w * ch, []
    prev, p = bytearray(stride), 0
    for _ in range(h):
        f, line = raw[p], bytearray(raw[p + 1 : p + 1 + stride])
        p += 1 + stride
        for x in range(stride):
            a = line[x - ch] if x >= ch else 0
            b = prev[x]
            c = prev[x - ch] if x >= ch else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                q = a + b - c
                pa, pb, pc = abs(q - a), abs(q - b), abs(q - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, ch, rows


def psnr(sq, n):
    return -10 * math.log10(sq / n) if sq > 0 else float("inf")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    room, obj = sys.argv[1], sys.argv[2]
    total = {"object": [0.0, 0], "rest": [0.0, 0]}
    parts = {"object's interior": [0.0, 0], "object's silhouette": [0.0, 0]}
    for name in sorted(os.listdir(room)):
        if not name.endswith(".png") or name.endswith("_gt.png"):
            continue
        view = name[:-4]
        w, h, cr, render = read_png(os.path.join(room, name))
        wg, hg, cg, truth = read_png(os.path.join(room, view + "_gt.png"))
        wo, ho, co, black = read_png(os.path.join(obj, view + "_gt.png"))
        if (wg, hg) != (w, h) or (wo, ho) != (w, h) or min(cr, cg, co) < 3:
            sys.exit(f"{view}: the render, its ground truth and the view on black differ in size or are not RGB")
        per = {"object": [0.0, 0], "rest": [0.0, 0]}
        mask = [[max(black[y][x * co + k] for k in range(3)) > OBJECT_LEVEL for x in range(w)] for y in range(h)]
        for y in range(h):
            for x in range(w):
                region = "object" if mask[y][x] else "rest"
                e = sum(((render[y][x * cr + k] - truth[y][x * cg + k]) / 255.0) ** 2 for k in range(3)) / 3
                for acc in (per[region], total[region]):
                    acc[0] += e
                    acc[1] += 1
                if mask[y][x]:
                    near = [mask[j][i] for j in range(max(0, y - 1), min(h, y + 2)) for i in range(max(0, x - 1), min(w, x + 2))]
                    part = parts["object's interior" if all(near) else "object's silhouette"]
                    part[0] += e
                    part[1] += 1
        print(view, "  ".join(f"{r} {psnr(*per[r]):.2f} dB ({per[r][1]} px)" for r in per))
    sq, n_all = sum(v[0] for v in total.values()), sum(v[1] for v in total.values())
    for r, (e, n) in total.items():
        print(f"all views, {r}: {psnr(e, n):.2f} dB over {n} px, {100 * e / sq:.0f} % of the squared error")
    print(f"all views, every pixel: {psnr(sq, n_all):.2f} dB over {n_all} px")
    for r, (e, n) in parts.items():
        share = 100 * e / total["object"][0] if total["object"][0] > 0 else 0
        print(f"all views, {r}: {psnr(e, n):.2f} dB over {n} px, {share:.0f} % of the object's squared error")


if __name__ == "__main__":
    main()
