#!/usr/bin/env python3
"""A hostile pass over the `nerf` command: every numeric flag of every
subcommand with out-of-range and malformed values, broken model files,
broken datasets (Blender, instant-ngp, LLFF, COLMAP), outputs aimed at
inputs, special files or others' files, configuration and camera-path
extremes, `nerf capture`'s failures (through a stand-in for COLMAP) and
interrupted commands. Each case must end within 60 s, without a panic,
with exit status 0 or a single `error:` line, the last on stderr (progress
and warnings before it allowed), and must leave the inputs it was given
unchanged.

    scripts/check/hostile_pass.py [--markdown]

Prints one row per class: cases tried, cases handled; lists the cases that
were not handled. Builds the release binary first.
"""
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(ROOT, "target", "release", "nerf")
MODEL = os.path.join(ROOT, "models", "scene.nerf")


def tree_digest(path):
    """Digest of every file under `path` (or of the file), to detect changes."""
    h = hashlib.sha256()
    if os.path.isfile(path):
        h.update(open(path, "rb").read())
        return h.hexdigest()
    for d, _, files in sorted(os.walk(path)):
        for f in sorted(files):
            p = os.path.join(d, f)
            h.update(p.encode())
            if os.path.isfile(p):
                h.update(open(p, "rb").read())
    return h.hexdigest()


def run_case(args, guard):
    """Runs `nerf args`; returns None if handled, else the reason."""
    before = {g: tree_digest(g) for g in guard}
    start = time.time()
    try:
        p = subprocess.run([BIN] + args, capture_output=True, timeout=60, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return "hang (over 60 s)"
    took = time.time() - start
    err = p.stderr.decode(errors="replace")
    if "panicked" in err or p.returncode < 0:
        return f"panic or signal (status {p.returncode}): {err.strip()[:200]}"
    for g in guard:
        if tree_digest(g) != before[g]:
            return f"changed an input: {g}"
    if p.returncode != 0:
        # progress and warnings may come first; the failure is one last line
        lines = err.strip().splitlines()
        errors = [l for l in lines if l.startswith("error:")]
        if len(errors) != 1 or lines[-1] != errors[0]:
            return f"not one error line: {err.strip()[:300]}"
    return None if took < 60 else "slow"


def main():
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
    work = tempfile.mkdtemp(prefix="nerf-hostile-")
    try:
        cases = build_cases(work)
        results = {}
        failures = []
        checked = [(cls, args, run_case(args, guard)) for cls, args, guard in cases] + interrupted_cases(work)
        for cls, args, why in checked:
            tried, ok = results.get(cls, (0, 0))
            results[cls] = (tried + 1, ok + (why is None))
            if why is not None:
                failures.append((cls, args, why))
        md = "--markdown" in sys.argv
        if md:
            print("| class | tried | handled |\n|---|---:|---:|")
        for cls, (tried, ok) in results.items():
            print(f"| {cls} | {tried} | {ok} |" if md else f"{cls:<40} {tried:>5} {ok:>5}")
        total = sum(t for t, _ in results.values())
        handled = sum(o for _, o in results.values())
        print(f"| all | {total} | {handled} |" if md else f"{'all':<40} {total:>5} {handled:>5}")
        for cls, args, why in failures:
            print(f"NOT HANDLED [{cls}] nerf {' '.join(args)}: {why}", file=sys.stderr)
        return 1 if failures else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


def build_cases(work):
    scene = os.path.join(work, "scene")
    subprocess.run([BIN, "scene", "--out", scene, "--size", "16", "--train", "4"], check=True, capture_output=True)
    blender = os.path.join(scene, "blender")
    nodata = os.path.join(work, "nodata")
    out = os.path.join(work, "out")
    cases = []

    # 1. every numeric flag with hostile values; the anchor makes valid values fail fast (missing data/model)
    values = ["-1", "0", "NaN", "inf", "-inf", "1e309", "99999999999999999999", "", "abc", "0x10", "1.5", "1e-9"]
    flags = {
        ("train", "--data", nodata, "--out", out, "--iters", "5"): [
            "--minutes", "--downscale", "--llffhold", "--seed", "--threads", "--checkpoint-secs", "--val-secs",
            "--val-views", "--log-every"],
        ("train", "--data", nodata, "--out", out, "--minutes", "1"): ["--iters"],
        ("eval", MODEL, "--data", nodata, "--split", "val"): [
            "--downscale", "--llffhold", "--threads", "--coarse", "--fine", "--early-stop", "--repeat"],
        ("render", MODEL, "--data", nodata, "--split", "val", "--out", out): [
            "--downscale", "--llffhold", "--size", "--threads"],
        ("render", MODEL, "--camera-path", nodata, "--out", out): ["--orbit", "--trajectory"],
        ("export", nodata, "--out", out): ["--bits", "--act-bits", "--grid-res", "--coarse", "--int8-layers"],
        ("tradeoff", MODEL, "--data", nodata, "--out", out): ["--downscale", "--llffhold", "--views", "--repeats"],
        ("fit", "--data", nodata, "--out", out, "--target-psnr", "20"): [
            "--downscale", "--minutes", "--early-stop", "--seed", "--threads", "--bits"],
        ("fit", "--data", nodata, "--out", out): ["--target-psnr"],
        ("scene", "--out", "/proc/nerf-hostile"): ["--size", "--train"],
        ("demo", "--out", "/proc/nerf-hostile"): ["--minutes"],
    }
    for anchor, fl in flags.items():
        for f in fl:
            for v in values:
                cases.append(("numbers out of range or malformed", list(anchor) + [f, v], [blender, MODEL]))

    # 2. broken model files, for every command that reads one
    models = os.path.join(work, "models")
    os.makedirs(models)
    good = open(MODEL, "rb").read()
    variants = {
        "empty.nerf": b"",
        "half.nerf": good[: len(good) // 2],
        "flip.nerf": good[:500] + bytes([good[500] ^ 8]) + good[501:],
        "random.nerf": os.urandom(4096),
        "header-only.nerf": good[:14],
        "png.nerf": open(os.path.join(blender, "train", "r_0.png"), "rb").read(),
    }
    for name, data in variants.items():
        open(os.path.join(models, name), "wb").write(data)
    bad_models = [os.path.join(models, n) for n in variants] + [models, "/dev/null", os.path.join(models, "missing.nerf")]
    loop = os.path.join(models, "loop.nerf")
    os.symlink(loop, loop)
    bad_models.append(loop)
    for m in bad_models:
        for args in (["info", m], ["info", m, "--json"], ["export", m, "--bits", "8", "--out", out + ".nerf"],
                     ["eval", m, "--data", blender, "--split", "val"],
                     ["render", m, "--orbit", "2", "--size", "8", "--out", out],
                     ["tradeoff", m, "--data", blender, "--out", out]):
            cases.append(("broken or missing model files", args, [blender]))

    # 3. broken datasets, through train (1 step) and eval
    import json
    datasets = os.path.join(work, "datasets")
    os.makedirs(datasets)
    base = json.load(open(os.path.join(blender, "transforms_train.json")))

    def blender_variant(name, mutate):
        d = os.path.join(datasets, name)
        shutil.copytree(blender, d)
        t = json.loads(json.dumps(base))
        mutate(t, d)
        open(os.path.join(d, "transforms_train.json"), "w").write(json.dumps(t) if not isinstance(t, str) else t)
        return d

    def set_(path, value):
        def f(t, d):
            cur = t
            for k in path[:-1]:
                cur = cur[k]
            cur[path[-1]] = value
        return f

    muts = {
        "no-frames": set_(["frames"], []),
        "huge-translation": set_(["frames", 0, "transform_matrix", 0, 3], 1e308),
        "3x3-pose": set_(["frames", 0, "transform_matrix"], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]),
        "scaled-pose": set_(["frames", 0, "transform_matrix", 0, 0], 2.0),
        "no-fov": lambda t, d: t.pop("camera_angle_x"),
        "zero-fov": set_(["camera_angle_x"], 0.0),
        "huge-fov": set_(["camera_angle_x"], 1e30),
        "negative-fov": set_(["camera_angle_x"], -1.0),
        "bad-near-far": set_(["near"], 9.0),
        "inverted-aabb": set_(["aabb"], [[1, 1, 1], [-1, -1, -1]]),
        "far-aabb": set_(["aabb"], [[100, 100, 100], [101, 101, 101]]),
        "missing-image": set_(["frames", 0, "file_path"], "./train/nothing"),
        "path-escape": set_(["frames", 0, "file_path"], "/etc/passwd"),
        "string-matrix": set_(["frames", 0, "transform_matrix"], "identity"),
        "fl-negative": lambda t, d: t.update({"fl_x": -5.0}),
    }
    broken = [blender_variant(n, m) for n, m in muts.items()]
    d = os.path.join(datasets, "truncated-json")
    shutil.copytree(blender, d)
    open(os.path.join(d, "transforms_train.json"), "w").write('{"camera_angle_x": 0.7, "frames": [')
    broken.append(d)
    d = os.path.join(datasets, "empty-image")
    shutil.copytree(blender, d)
    open(os.path.join(d, "train", "r_0.png"), "wb").write(b"")
    broken.append(d)
    d = os.path.join(datasets, "text-image")
    shutil.copytree(blender, d)
    open(os.path.join(d, "train", "r_1.png"), "w").write("not an image")
    broken.append(d)
    # COLMAP variants
    for name, edit in {
        "colmap-cut-cameras": lambda d: open(os.path.join(d, "sparse/0/cameras.bin"), "r+b").truncate(10),
        "colmap-cut-images": lambda d: open(os.path.join(d, "sparse/0/images.bin"), "r+b").truncate(100),
        "colmap-cut-points": lambda d: open(os.path.join(d, "sparse/0/points3D.bin"), "r+b").truncate(50),
        "colmap-no-images": lambda d: shutil.rmtree(os.path.join(d, "images")),
        "colmap-no-cameras": lambda d: os.remove(os.path.join(d, "sparse/0/cameras.bin")),
        "colmap-huge-count": lambda d: open(os.path.join(d, "sparse/0/points3D.bin"), "r+b").write(b"\xff" * 8),
    }.items():
        d = os.path.join(datasets, name)
        shutil.copytree(os.path.join(scene, "colmap"), d)
        edit(d)
        broken.append(d)
    for name, text in {
        "colmap-txt-fov-model": "1 FOV 16 16 10 10 8 8 0.5\n",
        "colmap-txt-nan": "1 PINHOLE 16 16 nan 10 8 8\n",
        "colmap-txt-garbage": "\x00\x01\x02 garbage\n",
        "colmap-txt-few-params": "1 OPENCV 16 16 10 10\n",
    }.items():
        d = os.path.join(datasets, name)
        shutil.copytree(os.path.join(scene, "colmap_text"), d)
        open(os.path.join(d, "sparse/0/cameras.txt"), "w").write(text)
        broken.append(d)
    # LLFF variants
    for name, data in {"llff-empty-npy": b"", "llff-bad-npy": b"\x93NUMPY\x01\x00\xff\xff{",
                       "llff-huge-shape": b"\x93NUMPY\x01\x00\x46\x00{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999, 99999999999), }"}.items():
        d = os.path.join(datasets, name)
        shutil.copytree(os.path.join(scene, "llff"), d)
        open(os.path.join(d, "poses_bounds.npy"), "wb").write(data)
        broken.append(d)
    broken += [nodata, work + "/scene/blender/train/r_0.png", "/dev/null", "/proc/self"]
    for d in broken:
        guard = [d] if os.path.exists(d) and d not in ("/dev/null", "/proc/self") else []
        for fmt in ("auto",):
            run_dir = os.path.join(work, "runs", os.path.basename(d.rstrip("/")) or "x")
            cases.append(("broken datasets", ["train", "--data", d, "--format", fmt, "--iters", "1", "--val-views", "0",
                                               "--out", run_dir], guard))
            cases.append(("broken datasets", ["eval", MODEL, "--data", d, "--split", "val"], guard))
            cases.append(("broken datasets", ["render", MODEL, "--data", d, "--split", "val", "--out", run_dir + "-r"],
                          guard))

    # 4. outputs aimed at inputs and special files
    copy = os.path.join(work, "copy.nerf")
    shutil.copy(MODEL, copy)
    link = os.path.join(work, "link.nerf")
    os.symlink(copy, link)
    fifo = os.path.join(work, "fifo.nerf")
    os.mkfifo(fifo)
    for o in [copy, link, fifo, "/dev/null", blender, os.path.join(blender, "train", "r_0.png"), "/proc/version"]:
        cases.append(("outputs onto inputs or special files", ["export", copy, "--bits", "8", "--out", o],
                      [copy, blender]))
    for o in [blender, os.path.join(blender, "train"), os.path.join(blender, "new")]:
        cases.append(("outputs onto inputs or special files", ["eval", MODEL, "--data", blender, "--split", "val",
                                                                 "--save", o], [blender]))
        cases.append(("outputs onto inputs or special files", ["render", MODEL, "--data", blender, "--split", "val",
                                                                 "--out", o], [blender]))
        cases.append(("outputs onto inputs or special files", ["train", "--data", blender, "--iters", "1", "--out", o],
                      [blender]))
        cases.append(("outputs onto inputs or special files", ["tradeoff", MODEL, "--data", blender, "--out", o],
                      [blender]))
        cases.append(("outputs onto inputs or special files", ["fit", "--data", blender, "--target-psnr", "20",
                                                                 "--out", o], [blender]))
    run = os.path.join(work, "run")
    subprocess.run([BIN, "train", "--data", blender, "--iters", "2", "--val-views", "0", "--out", run], check=True,
                   capture_output=True)
    for extra in ([], ["--resume", "--downscale", "2"], ["--resume", "--preset", "grid"], ["--resume", "--iters", "1"]):
        args = ["train", "--data", blender, "--val-views", "0", "--out", run] + (["--iters", "3"] if "--iters" not in extra else []) + extra
        cases.append(("runs into a folder that holds a run", args, [run, blender]))
    cases.append(("runs into a folder that holds a run", ["fit", "--data", blender, "--target-psnr", "20",
                                                          "--minutes", "0.01", "--out", run], [run, blender]))
    # every command that claims an output folder, with and without --force,
    # into a folder holding a user's file and into a training run: refused,
    # the folder untouched
    mine = os.path.join(work, "mine")
    os.makedirs(mine, exist_ok=True)
    open(os.path.join(mine, "frame_000.png"), "wb").write(b"my photo")
    for folder in (mine, run):
        claims = [["render", MODEL, "--orbit", "2", "--size", "8", "--out", folder],
                  ["scene", "--out", folder, "--size", "8", "--train", "2"],
                  ["eval", MODEL, "--data", blender, "--split", "val", "--save", folder],
                  ["tradeoff", MODEL, "--data", blender, "--out", folder],
                  ["web", MODEL, "--out", folder],
                  ["fit", "--data", blender, "--target-psnr", "20", "--minutes", "0.01", "--out", folder]]
        for args in claims:
            for force in ([], ["--force"]):
                cases.append(("output folders holding others' files", args + force, [folder, blender]))
    cases += capture_cases(work, scene, run)
    cases += extreme_cases(work, scene, run)
    return cases


def jpeg_claiming(src, dst, side):
    """A copy of the JPEG `src` whose frame header says `side` x `side` pixels."""
    b = bytearray(open(src, "rb").read())
    for marker in (b"\xff\xc0", b"\xff\xc2"):
        i = b.find(marker)
        if i >= 0:
            b[i + 5:i + 9] = side.to_bytes(2, "big") * 2
            break
    open(dst, "wb").write(bytes(b))


def capture_cases(work, scene, run):
    """Damaged photos, inputs that never end, outputs over the file read,
    captures that contradict themselves, camera-path fields, checkpoints
    given as models."""
    import json
    import struct
    cases = []
    colmap = os.path.join(scene, "colmap")
    caps = os.path.join(work, "captures")
    os.makedirs(caps)
    # damaged photos: a header claiming a huge frame, in every layout that reads JPEG
    for side in (60000, 30000, 65535):
        d = os.path.join(caps, f"huge-{side}")
        shutil.copytree(colmap, d)
        jpeg_claiming(os.path.join(colmap, "images", "img_002.jpg"), os.path.join(d, "images", "img_002.jpg"), side)
        for args in (["train", "--data", d, "--iters", "1", "--val-views", "0", "--out", os.path.join(work, "r-huge")],
                     ["eval", MODEL, "--data", d, "--split", "val", "--llffhold", "2"]):
            cases.append(("damaged photos", args, [d]))
    for layout in ("room_llff",):
        d = os.path.join(caps, f"huge-{layout}")
        shutil.copytree(os.path.join(scene, layout), d)
        jpeg_claiming(os.path.join(scene, layout, "images", "img_001.jpg"), os.path.join(d, "images", "img_001.jpg"),
                      60000)
        cases.append(("damaged photos", ["train", "--data", d, "--iters", "1", "--val-views", "0", "--out",
                                         os.path.join(work, "r-huge-llff")], [d]))
    # inputs that never end: FIFOs and devices named as files
    fifo = os.path.join(caps, "fifo.json")
    os.mkfifo(fifo)
    for f in (fifo, "/dev/zero", "/dev/urandom"):
        for args in (["render", MODEL, "--camera-path", f, "--size", "8", "--out", os.path.join(work, "r-fifo")],
                     ["info", f], ["web", f, "--out", os.path.join(work, "w-fifo")],
                     ["export", f, "--bits", "8", "--out", os.path.join(work, "x.nerf")],
                     ["train", "--data", colmap, "--iters", "1", "--config", f, "--out", os.path.join(work, "r-c")]):
            cases.append(("inputs that never end", args, [colmap]))
    # outputs over the file a command reads
    paths = os.path.join(caps, "paths")
    subprocess.run([BIN, "render", MODEL, "--orbit", "3", "--size", "8", "--out", paths], check=True,
                   capture_output=True)
    cp = os.path.join(paths, "camera_path.json")
    cases.append(("outputs over the file read", ["render", MODEL, "--camera-path", cp, "--size", "8", "--out", paths],
                  [cp]))
    # captures that contradict themselves
    def colmap_edit(name, edit):
        d = os.path.join(caps, name)
        shutil.copytree(os.path.join(scene, "colmap_text"), d)
        p = os.path.join(d, "sparse", "0")
        edit(p)
        cases.append(("captures that contradict themselves", ["train", "--data", d, "--iters", "1", "--val-views",
                                                               "0", "--out", os.path.join(work, "r-" + name)], [d]))

    def dup_image(p):
        lines = open(os.path.join(p, "images.txt")).read().splitlines()
        poses = [l for l in lines if l and not l.startswith("#")]
        first = poses[0].split()
        first[0] = "999"
        first[5] = str(float(first[5]) + 0.5)
        open(os.path.join(p, "images.txt"), "a").write(" ".join(first) + "\n\n")

    def off_centre(p):
        text = open(os.path.join(p, "cameras.txt")).read().splitlines()
        out = []
        for l in text:
            f = l.split()
            if l and not l.startswith("#") and f[1] == "PINHOLE":
                f[6] = "5000"
            out.append(" ".join(f))
        open(os.path.join(p, "cameras.txt"), "w").write("\n".join(out) + "\n")

    def one_image(p):
        lines = open(os.path.join(p, "images.txt")).read().splitlines()
        keep = [l for l in lines if l.startswith("#")]
        poses = [l for l in lines if l and not l.startswith("#")]
        open(os.path.join(p, "images.txt"), "w").write("\n".join(keep + poses[:1] + [""]) + "\n")

    def bom(p):
        text = open(os.path.join(p, "cameras.txt"), "rb").read()
        open(os.path.join(p, "cameras.txt"), "wb").write(b"\xef\xbb\xbf" + text)

    for name, e in {"duplicate-name": dup_image, "principal-point": off_centre, "one-image": one_image}.items():
        colmap_edit(name, e)
    # a byte-order mark is not a contradiction: the capture trains
    d = os.path.join(caps, "bom")
    shutil.copytree(os.path.join(scene, "colmap_text"), d)
    bom(os.path.join(d, "sparse", "0"))
    cases.append(("captures that contradict themselves", ["train", "--data", d, "--iters", "1", "--val-views", "0",
                                                           "--out", os.path.join(work, "r-bom")], [d]))
    # camera paths with bad fields
    eye = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1]
    bad_paths = {
        "fov0": {"camera_path": [{"camera_to_world": eye, "fov": 0, "aspect": 1}]},
        "fov-30": {"camera_path": [{"camera_to_world": eye, "fov": -30, "aspect": 1}]},
        "fov180": {"camera_path": [{"camera_to_world": eye, "fov": 180, "aspect": 1}]},
        "fov1e9": {"camera_path": [{"camera_to_world": eye, "fov": 1e9, "aspect": 1}]},
        "aspect0": {"camera_path": [{"camera_to_world": eye, "fov": 40, "aspect": 0}]},
        "no-aspect": {"camera_path": [{"camera_to_world": eye, "fov": 40}]},
        "no-matrix": {"camera_path": [{"fov": 40, "aspect": 1}]},
        "no-fps": {"keyframes": [{"matrix": eye, "fov": 40, "aspect": 1}], "seconds": 2},
        "negative-fps": {"keyframes": [{"matrix": eye, "fov": 40, "aspect": 1}], "fps": -24, "seconds": -2},
        "zero-size": {"camera_path": [{"camera_to_world": eye, "fov": 40}], "render_width": 0, "render_height": 0},
        "list": [1, 2],
    }
    for name, v in bad_paths.items():
        p = os.path.join(caps, name + ".json")
        open(p, "w").write(json.dumps(v))
        cases.append(("camera paths with bad fields", ["render", MODEL, "--camera-path", p, "--size", "8", "--out",
                                                        os.path.join(work, "r-path")], [p]))
    # checkpoints given as models
    ck = os.path.join(run, "checkpoint.bin")
    for args in (["info", ck], ["web", ck, "--out", os.path.join(work, "w-ck")],
                 ["eval", ck, "--data", colmap, "--split", "val"], ["render", ck, "--orbit", "2", "--out",
                                                                     os.path.join(work, "r-ck")]):
        cases.append(("checkpoints given as models", args, [run]))
    return cases


FAKE_COLMAP = """#!/bin/sh
stage=$1; shift
db=
while [ $# -gt 0 ]; do case $1 in --database_path) db=$2;; esac; shift; done
case $stage in
  help) echo "COLMAP 3.8 (a stand-in)";;
  feature_extractor) echo db > "$db";;
  mapper) echo "No good initial image pair found."; exit 1;;
esac
"""


def extreme_cases(work, scene, run):
    """Outputs onto others' files, configuration and camera-path extremes,
    `nerf capture`'s failures and messages that must lead somewhere."""
    import json
    cases = []
    blender = os.path.join(scene, "blender")
    room = os.path.join(scene, "room")
    ext = os.path.join(work, "extremes")
    os.makedirs(ext)
    # outputs onto others' files: a checkpoint, another model, a user's file, a folder
    ck = os.path.join(run, "checkpoint.bin")
    other = os.path.join(ext, "other.nerf")
    shutil.copy(MODEL, other)
    mine = os.path.join(ext, "notes.ply")
    open(mine, "w").write("my notes")
    for force in ([], ["--force"]):
        for target in (ck, other):
            cases.append(("outputs onto others' files", ["export", MODEL, "--bits", "8", "--out", target] + force,
                          [run] + ([other] if not force else [])))
    cases.append(("outputs onto others' files", ["mesh", MODEL, "--out", mine, "--resolution", "16"], [mine]))
    cases.append(("outputs onto others' files", ["mesh", MODEL, "--out", ext, "--resolution", "16"], [mine]))
    # configuration extremes: each refused at start naming the field
    configs = {
        "duplicate-key": '{"optimiser": {"lr": 0.01}, "optimiser": {"lr": 0.02}}',
        "lr-1e30": '{"lr": 1e30}',
        "lr-1e308": '{"lr": 1e308}',
        "decay": '{"feature_decay": -1}',
        "n-main-0": '{"n_main": 0}',
        "n-main-65535": '{"n_main": 65535}',
    }
    for name, text in configs.items():
        p = os.path.join(ext, name + ".json")
        open(p, "w").write(text)
        for data in (blender, room):
            cases.append(("configuration extremes", ["train", "--data", data, "--iters", "2", "--val-views", "0",
                                                     "--config", p, "--out", os.path.join(ext, "r-" + name)], [p]))
    # camera-path extremes
    eye = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1]
    paths = {
        "aspect-0.01": ({"camera_path": [{"camera_to_world": eye, "fov": 40, "aspect": 0.01}]}, "4096"),
        "bottom-row": ({"camera_path": [{"camera_to_world": eye[:12] + [1, 1, 1, 5], "fov": 40, "aspect": 1}]}, "8"),
        "seconds-1e308": ({"keyframes": [{"matrix": eye, "fov": 40, "aspect": 1}], "fps": 24, "seconds": 1e308},
                          "8"),
    }
    for name, (v, size) in paths.items():
        p = os.path.join(ext, name + ".json")
        open(p, "w").write(json.dumps(v))
        cases.append(("camera-path extremes", ["render", MODEL, "--camera-path", p, "--size", size, "--out",
                                                os.path.join(ext, "r-path")], [p]))
    # nerf capture: a program that is not COLMAP, photos it cannot use, COLMAP's failure read from its log
    fake = os.path.join(ext, "fake-colmap")
    open(fake, "w").write(FAKE_COLMAP)
    os.chmod(fake, 0o755)
    photos = os.path.join(blender, "train")
    junk = os.path.join(ext, "junk")
    os.makedirs(os.path.join(junk, "sub"))
    open(os.path.join(junk, "empty.jpg"), "w").close()
    open(os.path.join(junk, "text.jpg"), "w").write("not a photo")
    open(os.path.join(junk, "scan.tif"), "wb").write(b"II*\0")
    mixed = os.path.join(ext, "mixed")
    shutil.copytree(os.path.join(scene, "colmap", "images"), mixed)
    cap = os.path.join(ext, "cap")
    for args in (["--photos", photos, "--colmap", "/bin/true"],
                 ["--photos", junk, "--colmap", fake],
                 ["--photos", mixed, "--colmap", fake],
                 ["--photos", photos, "--colmap", fake],
                 ["--video", os.path.join(ext, "none.mp4"), "--colmap", fake]):
        cases.append(("nerf capture failures", ["capture", "--out", cap] + args, [photos, junk, mixed]))
    # messages: a flag that does not apply, a moved capture resumed
    cases.append(("messages", ["train", "--data", blender, "--iters", "1", "--val-views", "0", "--sparse-model", "1",
                               "--out", os.path.join(ext, "r-sparse")], [blender]))
    moved = os.path.join(ext, "moved")
    shutil.copytree(os.path.join(scene, "colmap"), moved)
    resumable = os.path.join(ext, "r-moved")
    subprocess.run([BIN, "train", "--data", os.path.join(scene, "colmap"), "--iters", "1", "--val-views", "0",
                    "--out", resumable], check=True, capture_output=True)
    cases.append(("messages", ["train", "--data", moved, "--iters", "2", "--val-views", "0", "--resume", "--out",
                               resumable], [moved]))
    return cases


def interrupted_cases(work):
    """Commands stopped by SIGINT part-way: each must end with one error
    line, leave no temporary file, and its own rerun must succeed."""
    import signal
    results = []
    for name, args, first in (
            ("render", ["render", MODEL, "--orbit", "2000", "--size", "24"], "orbit_001.png"),
            ("scene", ["scene", "--size", "64"], "blender")):
        out = os.path.join(work, "interrupted-" + name)
        p = subprocess.Popen([BIN] + args + ["--out", out], stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
        start = time.time()
        while not os.path.exists(os.path.join(out, first)) and time.time() - start < 60:
            time.sleep(0.02)
        p.send_signal(signal.SIGINT)
        err = p.communicate(timeout=60)[1].decode(errors="replace").strip()
        why = None
        lines = err.splitlines()
        if p.returncode != 1 or not lines or not lines[-1].startswith("error:"):
            why = f"status {p.returncode}: {err[-300:]}"
        elif any(".tmp" in f for _, _, fs in os.walk(out) for f in fs):
            why = "left a temporary file"
        else:
            rerun = [a if a != "2000" else "2" for a in args]
            r = subprocess.run([BIN] + rerun + ["--out", out], capture_output=True, timeout=120)
            if r.returncode != 0:
                why = "its rerun failed: " + r.stderr.decode(errors="replace").strip()[-300:]
        results.append(("interrupted commands", [*args, "--out", out, "(SIGINT)"], why))
    return results


if __name__ == "__main__":
    sys.exit(main())
