#!/usr/bin/env python3
"""Three copies of an instant-ngp / nerfstudio capture (transforms.json
and its photos), for measuring what nerfstudio's masks (mask_path) buy:

  OUT/clean/transforms.json   the capture as it is
  OUT/painted/transforms.json every training photo with an occluder painted
                              in (a solid rectangle of a random colour, 1/4
                              of the width and 2/5 of the height, at a random
                              place: something that moved through the shot)
  OUT/masked/transforms.json  the painted photos, each with a mask that
                              leaves its rectangle out

The training photos are the ones `nerf train --llffhold HOLDOUT` trains
on (the photos that exist, every HOLDOUT-th held out); held-out photos are
never painted, so all three score on the same views. The capture's own
files are only read. Frames must name their photos with the extension
(as fox's do), and photos in different folders must not share a name.
Needs Pillow.

  scripts/occluders.py DATA_DIR OUT [HOLDOUT] [SEED]
"""
import copy
import json
import os
import random
import sys

from PIL import Image, ImageDraw


def main():
    src, out = os.path.realpath(sys.argv[1]), sys.argv[2]
    holdout = int(sys.argv[3]) if len(sys.argv) > 3 else 8
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 0)
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
        img = Image.open(photo).convert("RGB")
        w, h = img.size
        rw, rh = w // 4, 2 * h // 5
        x, y = rng.randrange(w - rw), rng.randrange(h - rh)
        box = [x, y, x + rw - 1, y + rh - 1]
        ImageDraw.Draw(img).rectangle(box, fill=tuple(rng.randrange(256) for _ in range(3)))
        name = os.path.splitext(os.path.basename(photo))[0] + ".png"
        img.save(os.path.join(out, "photos", name))
        mask = Image.new("L", (w, h), 255)
        ImageDraw.Draw(mask).rectangle(box, fill=0)
        mask.save(os.path.join(out, "masks", name))
        painted["frames"][i]["file_path"] = masked["frames"][i]["file_path"] = os.path.join(out, "photos", name)
        masked["frames"][i]["mask_path"] = os.path.join(out, "masks", name)
    for name, c in [("clean", clean), ("painted", painted), ("masked", masked)]:
        json.dump(c, open(os.path.join(out, name, "transforms.json"), "w"), indent=1)
    print(f"{k} photos, {k - (k + holdout - 1) // holdout} painted", file=sys.stderr)


if __name__ == "__main__":
    main()
