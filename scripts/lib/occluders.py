#!/usr/bin/env python3
"""Three copies of a capture, for measuring what masks buy when something
moves through the photos:

  OUT/clean    the capture as it is
  OUT/painted  every training photo with an occluder painted in (a solid
               rectangle of a random colour, 1/4 of the width and 2/5 of
               the height, at a random place)
  OUT/masked   the painted photos, each with a mask that leaves its
               rectangle out

An instant-ngp / nerfstudio capture (DATA_DIR/transforms.json) gets
transforms files whose frames name the photos (`file_path`) and masks
(nerfstudio's `mask_path`); a COLMAP capture (DATA_DIR/images and
DATA_DIR/sparse/0, binary or text) gets folders holding links to its
sparse model, its photos (the painted ones written losslessly, PNG data
under the photo's own name, which the loaders read by content) and, for
the masked copy, a masks/ folder (`masks/NAME.png`, COLMAP's naming).

The training photos are the ones `nerf train --llffhold HOLDOUT` trains
on (the frames whose photo exists, or the images COLMAP registered in
name order; every HOLDOUT-th held out); held-out photos are never
painted, so all three score on the same views. The capture's own files
are only read. Frames must name their photos with the extension (as
fox's do), and photos in different folders must not share a name. Needs
Pillow.

  scripts/lib/occluders.py DATA_DIR OUT [HOLDOUT] [SEED]
"""
import copy
import json
import os
import random
import struct
import sys

from PIL import Image, ImageDraw


def occlude(photo, rng):
    """The photo with its occluder painted in, and the occluder's mask."""
    img = Image.open(photo).convert("RGB")
    w, h = img.size
    rw, rh = w // 4, 2 * h // 5
    x, y = rng.randrange(w - rw), rng.randrange(h - rh)
    box = [x, y, x + rw - 1, y + rh - 1]
    ImageDraw.Draw(img).rectangle(box, fill=tuple(rng.randrange(256) for _ in range(3)))
    mask = Image.new("L", (w, h), 255)
    ImageDraw.Draw(mask).rectangle(box, fill=0)
    return img, mask


def ngp(src, out, holdout, rng):
    t = json.load(open(os.path.join(src, "transforms.json")))
    for d in ["clean", "painted", "masked", "photos", "masks"]:
        os.makedirs(os.path.join(out, d), exist_ok=True)
    clean, painted, masked = copy.deepcopy(t), copy.deepcopy(t), copy.deepcopy(t)
    k = 0  # index among the frames whose photo exists, as the loader counts them
    for i, f in enumerate(t["frames"]):
        photo = os.path.join(src, f["file_path"].replace("\\", "/"))
        if not os.path.isfile(photo):
            continue
        for c in (clean, painted, masked):
            c["frames"][i]["file_path"] = photo
        held_out = k % holdout == 0
        k += 1
        if held_out:
            continue
        img, mask = occlude(photo, rng)
        name = os.path.splitext(os.path.basename(photo))[0] + ".png"
        img.save(os.path.join(out, "photos", name))
        mask.save(os.path.join(out, "masks", name))
        painted["frames"][i]["file_path"] = masked["frames"][i]["file_path"] = os.path.join(out, "photos", name)
        masked["frames"][i]["mask_path"] = os.path.join(out, "masks", name)
    for name, c in [("clean", clean), ("painted", painted), ("masked", masked)]:
        json.dump(c, open(os.path.join(out, name, "transforms.json"), "w"), indent=1)
    return k


def registered(model):
    """The names of the images a COLMAP model registers (images.bin or images.txt)."""
    names = []
    path = os.path.join(model, "images.bin")
    if os.path.isfile(path):
        with open(path, "rb") as f:
            (n,) = struct.unpack("<Q", f.read(8))
            for _ in range(n):
                f.read(4 + 7 * 8 + 4)  # id, qvec, tvec, camera id
                name = b""
                while (c := f.read(1)) != b"\0":
                    name += c
                names.append(name.decode())
                (points,) = struct.unpack("<Q", f.read(8))
                f.read(points * 24)
        return names
    lines = [l for l in open(os.path.join(model, "images.txt")) if l.strip() and not l.lstrip().startswith("#")]
    return [l.split(None, 9)[9].strip() for l in lines[::2]]


def colmap(src, out, holdout, rng):
    names = sorted(registered(os.path.join(src, "sparse", "0")))
    for d in ["clean", "painted/images", "masked/masks"]:
        os.makedirs(os.path.join(out, d), exist_ok=True)
    os.symlink(os.path.join(src, "images"), os.path.join(out, "clean", "images"))
    os.symlink(os.path.join(out, "painted", "images"), os.path.join(out, "masked", "images"))
    for c in ["clean", "painted", "masked"]:
        os.symlink(os.path.join(src, "sparse"), os.path.join(out, c, "sparse"))
    for k, name in enumerate(names):
        photo, copy_to = os.path.join(src, "images", name), os.path.join(out, "painted", "images", name)
        os.makedirs(os.path.dirname(copy_to), exist_ok=True)
        if k % holdout == 0:
            os.symlink(photo, copy_to)
            continue
        img, mask = occlude(photo, rng)
        img.save(copy_to, format="PNG")
        mask_to = os.path.join(out, "masked", "masks", name + ".png")
        os.makedirs(os.path.dirname(mask_to), exist_ok=True)
        mask.save(mask_to)
    return len(names)


def main():
    src, out = os.path.realpath(sys.argv[1]), os.path.realpath(sys.argv[2])
    holdout = int(sys.argv[3]) if len(sys.argv) > 3 else 8
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 0)
    os.makedirs(out, exist_ok=True)
    if os.path.isfile(os.path.join(src, "transforms.json")):
        k = ngp(src, out, holdout, rng)
    else:
        k = colmap(src, out, holdout, rng)
    print(f"{k} photos, {k - (k + holdout - 1) // holdout} painted", file=sys.stderr)


if __name__ == "__main__":
    main()
