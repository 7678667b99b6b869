#!/usr/bin/env python3
"""Writes docs/RESULTS.md and the README's results table from the CSV files
the measurement scripts append to (docs/*.csv). Each table shows the latest
row for each of its keys, with the date, commit, CPU and core count of the
run that measured it. Run by scripts/results.sh after its measurements;
standard library only.

    scripts/lib/results_md.py [REPO_ROOT]
"""

import csv
import os
import re
import subprocess
import sys

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
DOCS = os.path.join(ROOT, "docs")


def rows(name):
    """The rows of docs/NAME, or [] when the measurement never ran."""
    path = os.path.join(DOCS, name)
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def latest(rs, *key):
    """The last row of each key, in the order keys first appear."""
    out = {}
    for r in rs:
        k = tuple(r[c] for c in key)
        out.pop(k, None)
        out[k] = r
    return list(out.values())


def cpu(r):
    return re.sub(r"\((R|TM)\)", "", r["cpu"]).replace("  ", " ").strip()


def run(r):
    """The stamp of a row: date, commit, CPU model and cores."""
    return f"{r['date']} `{r['commit']}` {cpu(r)}, {r['cores']} cores"


def thousands(v):
    return f"{int(v):,}".replace(",", " ")


def table(header, body):
    align = ["---" if h.startswith("<") else "--:" for h in header]
    head = [h.lstrip("<") for h in header]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)


def missing(name):
    return f"Not measured yet: `scripts/results.sh {name}`."


# Each section: (heading, name for scripts/results.sh, what it measures, the table's markdown).


def default_section():
    rs = sorted(latest(rows("lego_default.csv"), "minutes", "seed"), key=lambda r: (float(r["minutes"]), r["seed"]))
    body = [
        [r["minutes"], r["seed"], thousands(r["steps"]), f"**{r['psnr_f32']}**", r["ssim_f32"], r["psnr_int8"],
         r["samples_int8"], r["us_f32"], f"**{r['us_int8']}**", thousands(r["bytes_int8"]), r["clear_opacity"], run(r)]
        for r in rs
    ]
    t = table(["minutes", "seed", "steps", "PSNR f32", "SSIM f32", "PSNR int8", "samples/ray", "µs/ray f32",
               "µs/ray int8", "int8 bytes", "clear_opacity", "<run"], body)
    return ("The default on lego", "default", """`scripts/measure/lego_default.sh DATA_ROOT MINUTES 0 1` for 1 and 10
minutes: `nerf train --data lego --downscale 8 --minutes M --val-views 0
--seed S` with no preset (the default, `features`), `nerf export --bits 8`,
then `nerf eval --split val --early-stop 1e-3 --threads 1 --repeat 2` on the
f32 model and its int8 export: PSNR and SSIM on lego's 10 validation views
at 100×100, samples and µs per ray on one core (the faster of two renders
of each view). `clear_opacity` is the mean rendered opacity over the pixels
whose photo is transparent (haze in empty space; 0 is none).""", t if rs else missing("default"))


def full_rows():
    """The latest docs/lego_full.csv row of each downscale, finest first."""
    return sorted(latest(rows("lego_full.csv"), "downscale"), key=lambda r: int(r["downscale"]))


def fast_int8_rows():
    """The latest docs/fast_int8.csv row of each configuration, steps and render."""
    return latest(rows("fast_int8.csv"), "config", "steps", "early_stop", "coarse")


def lego_size(r):
    """Lego's 800×800 photos at the row's downscale, as `N×N`."""
    n = 800 // int(r["downscale"])
    return f"{n}×{n}"


def full_section():
    rs = full_rows()
    size = lego_size
    body = [[size(r), r["minutes"], thousands(r["steps"]), f"{r['max_res']} / 2^{r['log2_table']}", r["coarse"],
             f"**{r['psnr_f32']}**", r["ssim_f32"], r["psnr_int8"], r["samples_f32"], r["us_f32"], r["us_int8"],
             thousands(r["bytes_f32"]), thousands(r["bytes_int8"]), thousands(r["peak_rss_mib"]), run(r)] for r in rs]
    t = table(["size", "minutes", "steps", "finest cells / entries", "samples", "PSNR f32", "SSIM f32", "PSNR int8",
               "evaluated/ray", "µs/ray f32", "µs/ray int8", "f32 bytes", "int8 bytes", "peak MiB", "<run"], body)
    curves = []
    for r in rs:
        c = []
        for p in rows("lego_full_curve.csv"):
            if (p["date"], p["commit"], p["downscale"], p["minutes"]) == (r["date"], r["commit"], r["downscale"],
                                                                          r["minutes"]):
                # a run's points are in training order: an earlier time starts a later run
                if c and float(p["train_minutes"]) < float(c[-1]["train_minutes"]):
                    c = []
                c.append(p)
        if c:
            curves.append(f"Validation PSNR over training time at {size(r)} (2 views, `train.jsonl`):\n\n" + table(
                ["minutes"] + [p["train_minutes"] for p in c], [["dB"] + [p["val_psnr"] for p in c]]))
    return ("The default at full resolution", "full", """`scripts/measure/lego_full.sh DATA_ROOT MINUTES DOWNSCALE`: `nerf train --data lego
--downscale D --minutes M` with no preset, its feature grid sized to the
photos (finest level and table entries per level in the table) and its
samples per ray set for them (`samples`; the network evaluates the
`evaluated/ray` of them in occupied cells before early termination), then
`nerf export --bits 8` and `nerf eval --split val --early-stop 1e-3
--threads 1 --repeat 2` on the f32 model and its int8 export: PSNR and
SSIM on lego's 10 validation views, samples and µs per ray on one core;
peak MiB is the training process's peak resident memory.""",
            "\n\n".join([t] + curves) if rs else missing("full"))


def tradeoff_section():
    rs = rows("tradeoff_lego8.csv")
    if not rs or "commit" not in rs[0]:
        return ("The trade: PSNR against cost", "tradeoff", "", missing("tradeoff"))
    body = [[r["label"], r["psnr"], r["ssim"], r["us_per_ray"], r["samples_per_ray"],
             "yes" if r["pareto"] == "true" else ""] for r in rs]
    t = table(["<point", "PSNR", "SSIM", "µs/ray", "samples/ray", "<Pareto front"], body)
    return ("The trade: PSNR against cost", "tradeoff", f"""`scripts/measure/tradeoff.sh DATA_ROOT 10`: the default trained
{rs[0]['minutes']} minutes on lego at 100×100 (seed 0), then `nerf tradeoff` on
the 10 validation views: weight bits (f32, int16, int8, int8 with 8-bit
activations), samples per ray and early termination varied one at a time
around the model's own settings; µs per ray on one thread, the median of 5
interleaved repetitions. Run: {run(rs[0])}.

![PSNR against µs per ray](tradeoff_lego8.png)""", t)


def int8_section():
    rs = latest(rows("int8_loss.csv"), "preset")
    body = [[r["preset"], r["minutes"], thousands(r["steps"]), r["psnr_f32"], r["psnr_int8"], f"**{r['loss_db']}**",
             thousands(r["bytes_f32"]), thousands(r["bytes_int8"]), r["us_f32"], r["us_int8"], run(r)] for r in rs]
    t = table(["<preset", "minutes", "steps", "PSNR f32", "PSNR int8", "int8 loss (dB)", "f32 bytes", "int8 bytes",
               "µs/ray f32", "µs/ray int8", "<run"], body)
    return ("int8 against f32, every preset", "int8-loss", """`scripts/measure/int8_loss.sh DATA_ROOT 3`: each preset trained for
3 minutes on lego at 100×100, exported with `nerf export --bits 8`, and
both models evaluated on the 10 validation views with the same samples and
early termination at 10⁻³ (µs per ray over the machine's cores). A preset
that trains few steps in 3 minutes is barely fitted; its loss says little
about a trained model of that preset.""", t if rs else missing("int8-loss"))


def fast_int8_section():
    rs = fast_int8_rows()
    body = [[r["config"], thousands(r["steps"]), r["early_stop"], r["coarse"], f"**{r['psnr']}**", r["samples_per_ray"],
             f"**{r['us_per_ray']}**", thousands(r["bytes_int8"]), run(r)] for r in rs]
    t = table(["<configuration", "steps", "early termination", "samples per ray", "PSNR int8", "evaluated per ray",
               "µs/ray int8", "int8 bytes", "<run"], body)
    return ("int8 toward 1 µs per ray", "fast-int8", """`scripts/measure/fast_int8.sh DATA_ROOT 60000`: configurations that
trade accuracy for speed, each trained 60 000 steps on lego at 100×100 on
one thread with seed 0, exported with `nerf export --bits 8` and evaluated
on the 10 validation views on one core (the fastest of three renders per
view), with early termination at 10⁻³ and 10⁻², and at 10⁻² with 160,
144 and 128 stratified samples per ray instead of the trained 192 (`nerf
eval --coarse N`). Rows of one run compare; timings of different runs
move by a few per cent on this shared machine. `default` is the default configuration; `2x32` has
32-wide layers and no pixel footprint (`{"width": 32, "view_width": 32,
"footprint": false}`); `alpha` keeps an occupancy cell while a step
through it is at least that opaque (`grid_alpha`, 0.03 in the
default).""", t if rs else missing("fast-int8"))


def last_run(rs):
    """The rows of the last run (the last row's date and commit)."""
    return [r for r in rs if (r["date"], r["commit"]) == (rs[-1]["date"], rs[-1]["commit"])] if rs else []


def table_bits_section():
    rs = latest(last_run(rows("table_bits.csv")), "table_bits")
    wide = next((float(r["psnr"]) for r in rs if r["table_bits"] == "16"), None)
    body = [[r["table_bits"], f"**{r['psnr']}**", f"{float(r['psnr']) - wide:+.2f}" if wide is not None else "",
             r["ssim"], r["samples"], r["us"], f"**{thousands(r['bytes'])}**", thousands(r["table_bytes"]), run(r)]
            for r in rs]
    t = table(["table bits", "PSNR", "against 16 bits (dB)", "SSIM", "samples/ray", "µs/ray", "model bytes",
               "table bytes", "<run"], body)
    minutes = rs[0]["minutes"] if rs else "10"
    return ("The feature table in 16, 8 and 4 bits", "table-bits", f"""`scripts/measure/table_bits.sh DATA_ROOT {minutes}`: the default trained
{minutes} minutes on lego at 100×100 (seed 0), exported to int8 with
`nerf export --bits 8 --table-bits B` (16: i16 values; 8 and 4: indices
into a codebook of 256 or 16 values per level), and each export evaluated
with `nerf eval --split val --early-stop 1e-3 --threads 1 --repeat 2` on
the 10 validation views. Table bytes include the codebooks.""", t if rs else missing("table-bits"))


TREATMENTS = """- `auto`: no flag but the preset; the scene model (object box, forward-facing
  NDC or unbounded contraction) chosen from the cameras. `object`: `--scene
  object` forced (no room for what lies beyond the object).
- `no-distortion`: the lens's distortion coefficients ignored
  (`--ignore-distortion`); `lens`: rays bent through the lens (the default);
  `undistort`: photos resampled without distortion once at load
  (`--undistort`), scored against the photos as taken or, where the
  treatment says so, against the resampled photos (from 377aef6 on over
  the pixels the lens imaged, which alone train; before, over every
  pixel, those beyond the lens repeating the photo's edge).
- `features`: the default preset (`features`); the other treatments of
  `scripts/measure/captures.sh` train `--preset fast`.
- `scene-colmap` / `scene-room`: the built-in scene written by `nerf scene`
  as a 360° COLMAP capture on black / inside a coloured room
  (`scripts/measure/scene360.sh`).
- `… layout`: bird from its COLMAP folder and from the same cameras in
  the other layouts (`scripts/measure/layouts.sh DATA_ROOT 1500`): LLFF's
  `poses_bounds.npy`, and nerfstudio's `transforms.json` with its sparse
  points (`ply_file_path`) or without (the fit then has the cameras
  alone), each 1 500 steps on one thread, seed 0."""


def captures_section():
    rs = latest(rows("captures.csv"), "capture", "treatment")
    order = {"bird": 0, "fox": 1}
    rs.sort(key=lambda r: (order.get(r["capture"], 2), r["capture"]))
    body = [[r["capture"], r["treatment"], r["minutes"], thousands(r["steps"]), f"**{r['psnr']}**", r["ssim"], run(r)]
            for r in rs]
    t = table(["<capture", "<treatment", "minutes", "steps", "PSNR", "SSIM", "<run"], body)
    return ("Real captures", "captures", f"""`scripts/measure/captures.sh DATA_ROOT 5` (bird: COLMAP, 184 JPEG photos
walked around the object; fox: instant-ngp, JPEG, OpenCV lens distortion,
frames whose files are missing), `scripts/measure/lens.sh DATA_ROOT 1000 S` (fox at
equal steps, seeds 0 and 1: minutes are the training time) and `scripts/measure/scene360.sh 2`:
`nerf train --data CAPTURE --downscale 8 --minutes M` with no other flag
than the treatment's, scored by `nerf eval --split val` on the held-out
photos (every 8th image) at 1/8 size.

{TREATMENTS}{baseline_rerun()}""", t if rs else missing("captures"))


# the commit whose default the proposal sampling's quality target is measured against
BASELINE_COMMIT = "0cf40ca"


def baseline_rerun():
    """The default against BASELINE_COMMIT's, rerun on the same day and CPU:
    per capture, the latest baseline `features` row and the row that
    follows it (the same day and CPU)."""
    pending, paired = {}, {}
    for r in rows("captures.csv"):
        if r["treatment"] != "features":
            continue
        if r["commit"] == BASELINE_COMMIT:
            pending[r["capture"]] = r
        elif (b := pending.pop(r["capture"], None)) and (b["date"], b["cpu"]) == (r["date"], r["cpu"]):
            paired[r["capture"]] = (b, r)
    pairs = list(paired.values())
    if not pairs:
        return ""
    lines = [f"  - {r['capture']}: {b['psnr']} dB ({thousands(b['steps'])} steps) at {BASELINE_COMMIT}, "
             f"{r['psnr']} dB ({thousands(r['steps'])} steps) at {r['commit']}, "
             f"{float(r['psnr']) - float(b['psnr']):+.2f} dB; {r['date']}, {cpu(r)}, {r['cores']} cores"
             for b, r in pairs]
    return ("\n- The default against " + BASELINE_COMMIT + "'s (the occupancy grid's samples in unbounded\n"
            "  scenes), 5 minutes each, back to back on one machine (`scripts/measure/baseline_rerun.sh DATA_ROOT 5`):\n"
            + "\n".join(lines))


def proposal_section():
    every = rows("proposal.csv")
    lego_steps = ", ".join(f"{thousands(r['steps'])} on {r['commit']}" for r in every
                           if r["capture"] == "lego" and r["minutes"] == "5")
    rs = latest(every, "capture", "treatment")
    order = {"lego": 0, "bird": 1, "fox": 2, "room": 3, "room-on-black": 4}
    rs.sort(key=lambda r: (order.get(r["capture"], 5), r["treatment"]))
    lego = {r["commit"]: r for r in rs if r["capture"] == "lego"}

    def ratio(r, col):
        ref = lego.get(r["commit"])
        return f"{float(r[col]) / float(ref[col]):.1f}×" if ref and r is not ref else ""

    body = [[r["capture"], r["treatment"], thousands(r["steps"]), r["ms_per_step"], ratio(r, "ms_per_step"),
             f"**{r['psnr']}**", r["psnr_int8"], r["evaluations_per_ray"], r["us_per_ray_int8"],
             ratio(r, "us_per_ray_int8"), run(r)] for r in rs]
    t = table(["<capture", "<treatment", "steps", "ms/step", "× lego", "PSNR", "int8", "evaluated/ray",
               "µs/ray int8", "× lego", "<run"], body)
    return ("Real captures at the default", "proposal", """`BASELINE=1 scripts/measure/proposal.sh DATA_ROOT 5`: bird
(COLMAP), fox (instant-ngp), lego and the built-in room (`nerf scene`, 64×64;
and the same scene on black, `--scene object`) trained 5 minutes each with
no flag but `--data`, `--downscale 8` (the room at full size) and `--out`,
back to back on one machine: unbounded captures get the proposal grid that
places the network's samples, object scenes the occupancy grid's stratified
samples. The default composites the proposal grid at 128 stratified
samples, trains the network at 32 (rendering at 32 up to 3e04c50, at 16
with `sampling.n_main_render`) and, from 0a4ff61 on, adds the
distortion loss at 0.001 in unbounded scenes (`capture-5m` in
"Configurations compared on a capture" measures the loss): the rows of
3e04c50 are of that default, rendered at the 32 network samples they
were trained with; older rows, where no newer one replaces them, are of
aee59e8's default, 192 and 48 samples. Models with
`sampling.n_main_render` render at 16 network samples unless told
otherwise; "The network's samples per ray with a proposal grid" and
"Instructions per ray of the real captures" below measure that. Lego's steps in
these runs (""" + lego_steps + """) differ with the machine and its load on
one CPU model, so compare rows of one commit; "Instructions per ray"
below gives the ray-cost ratio as a count that does not move with the
load. ms per step is the run's wall time over its steps; PSNR on the
held-out views (every 8th photo; lego's 10 validation views) in f32 and
after `nerf export --bits 8`; the int8 render on one core with early
termination 10⁻³ (`nerf eval --threads 1 --repeat 3 --early-stop 1e-3`,
the fastest of three). "no proposal grid" rows are the same runs with
`--config '{"proposal_res": 0}'`; "× lego" compares with lego's row of the
same run (aee59e8's lego row is not shown, so its rows have none).""", t if rs else missing("proposal"))


def proposal_samples_section():
    rs = latest(rows("proposal_samples.csv"), "capture", "stratified", "samples")
    rs.sort(key=lambda r: (r["capture"], -int(r["stratified"]), int(r["samples"])))
    body = [[r["capture"], r["stratified"], r["samples"], f"**{r['psnr']}**", r["evaluations_per_ray"],
             r["us_per_ray"], run(r)] for r in rs]
    t = table(["<capture", "stratified", "network samples", "PSNR int8", "evaluated/ray", "µs/ray", "<run"], body)
    return ("The network's samples per ray with a proposal grid", "proposal", """`scripts/measure/proposal_samples.sh
MODEL DATA CAPTURE` (run by `scripts/measure/proposal.sh` on its bird and fox
models, trained with 192 stratified and 48 network samples in the rows of
aee59e8, with 128 and 32 in those of 6f7ebdc and 3e04c50; in the rows of
a67d798, by `scripts/measure/main_samples.sh` on its models trained at 32): the
int8 export rendered on the held-out views with S stratified samples
compositing the proposal grid and N network samples drawn from its weights
(`nerf eval --coarse S --fine N`), one core, early termination 10⁻³, the
fastest of three. The network's samples are placed where the grid's weight
is, so early termination cuts few of them: the time follows the counts,
and the grid's pass at the stratified samples is part of every row's.
A model that `nerf train` gives a proposal grid renders at 16 unless
told otherwise (`sampling.n_main_render`).""", t if rs else missing("proposal"))


def main_samples_section():
    rs = latest(rows("main_samples.csv"), "capture", "n_main")
    order = {"lego": 0, "bird": 1, "fox": 2, "room": 3}
    rs.sort(key=lambda r: (order.get(r["capture"], 4), -int(r["n_main"]) if r["n_main"].isdigit() else 0))
    lego = {r["commit"]: r for r in rs if r["capture"] == "lego"}

    def ratio(r, col, digits):
        ref = lego.get(r["commit"])
        ok = ref and r is not ref and r[col] and ref[col]
        return f"{float(r[col]) / float(ref[col]):.{digits}f}×" if ok else ""

    body = [[r["capture"], r["n_main"], thousands(r["steps"]), r["ms_per_step"], ratio(r, "ms_per_step", 1),
             f"**{r['psnr']}**", r["psnr_int8"], r["evaluations_per_ray"], r["us_per_ray_int8"],
             ratio(r, "us_per_ray_int8", 1),
             thousands(r["instructions_per_ray"]) if r["instructions_per_ray"] else "",
             ratio(r, "instructions_per_ray", 2), run(r)] for r in rs]
    t = table(["<capture", "n_main", "steps", "ms/step", "× lego", "PSNR", "int8", "evaluated/ray", "µs/ray int8",
               "× lego", "instructions/ray", "× lego", "<run"], body)
    return ("The network's samples per ray in training", "main-samples", """`scripts/measure/main_samples.sh DATA_ROOT 5
16 32`: bird and fox at 1/8 size and the built-in room (64×64) trained 5
minutes with `--config '{"sampling": {"n_main": N, "n_main_render": 0}}'`
and no other flag (each model renders at its own count; ea34d60, which
has no `n_main_render`, was given `n_main` alone, with the same effect),
and lego at 1/8 size at the default (no proposal grid: `n_main` does not
apply), back to back on one machine. PSNR on the held-out views in f32 and
after `nerf export --bits 8`; the int8 render on one core with early
termination 10⁻³ (the fastest of three); instructions per ray counted by
callgrind on the int8 render (a build for x86-64-v3) at 1/16 size for the
photo captures and lego and at full size for the room. "× lego" compares
with lego's row of the same run. Unlike the table above, which renders
one model at fewer samples than it was trained with, each row here is a
model trained at its count.""", t if rs else missing("main-samples"))


def room_region_section():
    rs = rows("room_region.csv")
    for r in rs:
        r["length"] = f"{r['minutes']} min" if r["minutes"] else f"{thousands(r['steps'])} steps"
    rs = latest(rs, "commit", "length", "seed", "capture", "configuration")
    black = {(r["commit"], r["length"], r["seed"]): r for r in rs if r["capture"] == "on-black"}

    def gap(r):
        ref = black.get((r["commit"], r["length"], r["seed"]))
        ok = ref and r is not ref
        return f"{float(ref['object_psnr']) - float(r['object_psnr']):.2f}" if ok else ""

    body = [[r["capture"], f"`{r['configuration']}`", r["length"], r["seed"], thousands(r["steps"]), r["psnr"],
             f"**{r['object_psnr']}**", gap(r), r["rest_psnr"], r["all_psnr"], run(r)] for r in rs]
    t = table(["<capture", "<configuration", "length", "seed", "steps", "PSNR", "object's pixels",
               "below on black", "the rest", "every pixel", "<run"], body)
    # the mean over seeds of each configuration run from more than one
    groups = {}
    for r in rs:
        groups.setdefault((r["commit"], r["length"], r["capture"], r["configuration"]), []).append(r)
    mean_rows = []
    for (commit, length, cap, conf), g in groups.items():
        if len(g) < 2:
            continue
        m = lambda col: sum(float(r[col]) for r in g) / len(g)
        refs = [black.get((commit, length, r["seed"])) for r in g]
        below = ""
        if cap != "on-black" and all(refs):
            below = f"{sum(float(b['object_psnr']) for b in refs) / len(refs) - m('object_psnr'):.2f}"
        mean_rows.append([cap, f"`{conf}`", length, ", ".join(r["seed"] for r in g), f"{m('psnr'):.2f}",
                          f"**{m('object_psnr'):.2f}**", below, f"{m('rest_psnr'):.2f}", f"{m('all_psnr'):.2f}",
                          run(g[0])])
    if mean_rows:
        t += "\n\nThe mean over the seeds of each configuration run from several:\n\n" + table(
            ["<capture", "<configuration", "length", "seeds", "PSNR", "object's pixels", "below on black",
             "the rest", "every pixel", "<run"], mean_rows)
    return ("The room's object against the object on black", "room-region", """`scripts/measure/room_region.sh LENGTH
SEEDS CONFIG...`: the built-in scene (`nerf scene --size 64`) on black trained
with `--scene object`, then inside its coloured room with each
configuration (the default with its fields on top), back to back, each
for LENGTH (minutes, or a number of steps) with no other flag, from each
seed. PSNR: the mean over the held-out views,
as `nerf eval` gives it (the room's models render at their default,
16 network samples); then `scripts/lib/region_psnr.py`'s pooled PSNR over
the object's pixels (those that are not black in the same view on
black: 8 131 of 28 672), over the rest, and over every pixel. "below on
black" is the object's pixels' PSNR on black (the row of the same
commit, length and seed) less the room's. The rows of `8168497` compare
a stretch of the contraction around the object (`--focus-zoom`, 2 its
default there, 1 the plain contraction of every other row), a build not
kept: docs/EXPERIMENTS.md, "A capture with surroundings".""", t if rs else missing("room-region"))


def seeds_section():
    rs = latest(rows("seeds.csv"), "commit", "capture", "steps", "seed")
    commits = list(dict.fromkeys(r["commit"] for r in rs))
    runs = {(r["commit"], r["capture"], r["steps"], r["seed"]): r for r in rs}
    keys = list(dict.fromkeys((r["capture"], r["steps"], r["seed"]) for r in rs))

    def cell(c, k):
        r = runs.get((c, *k))
        return f"{r['psnr']} ({r['dark_steps']})" if r else ""

    body = [[cap, thousands(steps), seed] + [cell(c, (cap, steps, seed)) for c in commits] for cap, steps, seed in keys]
    for cap, steps in dict.fromkeys((k[0], k[1]) for k in keys):
        got = [[r for r in rs if r["commit"] == c and (r["capture"], r["steps"]) == (cap, steps)] for c in commits]
        body.append([cap, thousands(steps), "mean; went dark"] + [
            f"{sum(float(r['psnr']) for r in g) / len(g):.2f}; {sum(int(r['dark_steps']) > 0 for r in g)} of {len(g)}"
            if g else "" for g in got])
    first = {c: next(r for r in rs if r["commit"] == c) for c in commits}
    stamps = "; ".join(f"`{c}` on {r['date']}, {cpu(r)}, {r['cores']} cores" for c, r in first.items())
    t = table(["<capture", "steps", "seed"] + [f"PSNR (dark steps) at `{c}`" for c in commits], body)
    return ("The default from several seeds", "seeds", f"""`scripts/measure/seeds.sh DATA_DIR STEPS SEED...`: a capture trained
STEPS steps at the default from each seed, back to back, scored on its
held-out views (`nerf eval`); in brackets, the steps whose batch PSNR
was 3 dB or more below the first step's: a field gone dark, rendering
only the background. A commit's column is a build of that commit
(`NERF_BIN`, `NERF_COMMIT`), run {stamps}.""", t if rs else missing("seeds"))


def ray_instructions_section():
    rs = latest(rows("ray_instructions.csv"), "capture", "scheme")
    order = {"lego": 0, "bird": 1, "fox": 2, "room": 3}
    rs.sort(key=lambda r: (order.get(r["capture"].split()[0], 4), r["capture"], r["scheme"]))
    lego = {(r["commit"], r["scheme"]): r for r in rs if r["capture"] == "lego"}

    def ratio(r):
        ref = lego.get((r["commit"], r["scheme"]))
        return f"{int(r['instructions_per_ray']) / int(ref['instructions_per_ray']):.2f}×" if ref and r is not ref else ""

    body = [[r["capture"], r["scheme"], r["downscale"], thousands(r["rays"]), r["evaluations_per_ray"],
             thousands(r["instructions_per_ray"]), ratio(r), r["psnr"], run(r)] for r in rs]
    t = table(["<capture", "<scheme", "downscale", "rays", "evaluated/ray", "instructions/ray", "× lego", "PSNR",
               "<run"], body)
    return ("Instructions per ray of the real captures", "proposal", """`scripts/measure/ray_instructions.sh CAPTURE
MODEL DATA [DOWNSCALE]` (run by `scripts/measure/proposal.sh` on its int8
exports where valgrind is installed): callgrind's count of `render_view`
over the held-out views at the size they were trained at (1/8 of the
photos; the room's 64×64 views whole), one thread, early termination
10⁻³, over the rays rendered, with a build for x86-64-v3 (AVX2; valgrind
cannot run AVX-512). Unlike µs per ray, the count does not move with the
machine's load, so "× lego" (lego's row of the same commit) is the
stable form of the ray-cost ratio; it leaves out what the count cannot
see, such as cache misses in a larger model. Rows named "CAPTURE --fine
N" count the capture's model exported to render at N network samples
(`nerf export MODEL --bits 8 --fine N`; 16 is what `nerf train` sets for
a capture with a proposal grid), by `scripts/measure/main_samples.sh` on its
models trained at 32 (`RENDER="16 20 24"`).""", t if rs else missing("proposal"))


def ray_stages_section():
    rs = rows("ray_stages.csv")
    # the latest run of each capture and scheme
    keys = {}
    for r in rs:
        keys[(r["capture"], r["scheme"])] = (r["date"], r["commit"])
    last = [r for r in rs if keys[(r["capture"], r["scheme"])] == (r["date"], r["commit"])]
    order = {"lego": 0, "bird": 1, "fox": 2, "room": 3}
    last.sort(key=lambda r: (order.get(r["capture"], 4), r["capture"], r["scheme"] != "I8"))
    body = [[r["capture"], r["scheme"], r["stage"], thousands(r["instructions_per_ray"]),
             f"{100 * float(r['share']):.1f} %", r["d1_misses_per_ray"], r["ll_misses_per_ray"], run(r)] for r in last]
    t = table(["<capture", "<scheme", "<stage", "instructions/ray", "share", "D1 misses/ray", "LL misses/ray", "<run"],
              body)
    return ("Where a ray's work goes", "ray-stages", """`scripts/measure/ray_stages.sh CAPTURE MODEL
DATA [DOWNSCALE]`: callgrind with its cache simulator over `nerf eval
MODEL --split val` at 1/8 of the photos, one thread, early termination
10⁻³ (a build for x86-64-v3: valgrind cannot run AVX-512), each
function's own cost put in a stage by the source file its code comes from
(inlined code keeps its file): the feature grid (the corners' gathers and
their interpolation), the positional encoding, the network's layers,
compositing, the march (samples, skipping, the proposal grid, the ray's
bookkeeping), memory fills, and the rest (ray setup, kernel dispatch, the
evaluation's own loop). Misses are of valgrind's model of this machine's
caches (32 KiB first-level data cache), not the CPU's counters. Models:
the default trained 3 minutes at 1/8 size (lego at 100×100, bird) and its
int8 export.""", t if rs else missing("ray-stages"))


def capture_ab_section():
    rs = rows("capture_ab.csv")
    for r in rs:
        r["length"] = f"{r['minutes']} min" if r["minutes"] else f"{thousands(r['steps'])} steps"
    rs = latest(rs, "capture", "length", "configuration")
    body = [[r["capture"], r["length"], f"`{r['configuration']}`", thousands(r["steps"]), r["ms_per_step"],
             f"**{r['psnr']}**", r["psnr_right_half"], r["psnr_right_half_corrected"], r["psnr_int8"],
             r["evaluations_per_ray"], r["us_per_ray_int8"], run(r)] for r in rs]
    t = table(["<capture", "<length", "<configuration", "steps", "ms/step", "PSNR", "right halves",
               "corrected", "int8", "evaluated/ray", "µs/ray int8", "<run"], body)
    return ("Configurations compared on a capture", "capture-ab", """`scripts/measure/capture_ab.sh DATA LENGTH
CONFIG...` (the commands are `scripts/results.sh --list`'s `capture-ab`,
`capture-5m`, `capture-ff` and `capture-pose`, whose `bird-off-0.5-0.01`
is bird with its training photos' poses turned and moved at random,
`scripts/measure/pose_perturbed.sh`): the capture trained at 1/8 size (the
built-in room, `room`, and forward-facing capture, `llff`: `nerf scene
--size 64` at full size) for a number of steps (the rows compare
at equal steps) or minutes (at equal time, back to back), seed 0, the
default with the configuration's fields on top (`--config`; `{}` is the
default). PSNR on the held-out views at the field's own colour; "right
halves" the same renders' right halves, and "corrected" those halves
after an affine colour correction fitted on each view's left half
(`scripts/lib/appearance_half.py`); int8: the `--bits 8` export, rendered on
one core with early termination 10⁻³. ms per step is the run's wall time
(loading included) over its steps.""", t if rs else missing("capture_ab"))


def masks_section():
    rs = latest(rows("masks.csv"), "capture", "copy", "steps")
    what = {"clean": "as captured", "painted": "occluders painted in", "masked": "occluders painted in, masked"}
    body = [[r["capture"], what.get(r["copy"], r["copy"]), thousands(r["steps"]), r["train_seconds"],
             f"**{r['psnr']}**", r["ssim"], run(r)] for r in rs]
    t = table(["<capture", "<training photos", "steps", "s", "PSNR", "SSIM", "<run"], body)
    return ("Masks: something moving through the photos", "masks", """`scripts/measure/masks.sh DATA ITERS`:
`scripts/lib/occluders.py` paints a rectangle of a random colour over a
tenth of every training photo of a capture (a quarter of its width, two
fifths of its height, at a random place: something that moved through
the shot; the held-out photos untouched), and the capture is trained as
captured, painted, and painted with masks that leave the rectangles out
(fox: nerfstudio's `mask_path` in its `transforms.json`; bird: a
`masks/` folder beside its COLMAP `images/`), each at 1/8 size with the
default flags and seed 0, and scored on its held-out views. Seconds:
the run's wall time, loading included.""", t if rs else missing("masks"))


def plain_build_section():
    rs = latest(rows("plain_build.csv"), "model", "build")
    body = []
    for r in rs:
        other = [q for q in rs if q["build"] == r["build"] and q["model"] != r["model"] and q["commit"] == r["commit"]]
        ratio = f"{float(r['us_per_ray']) / float(other[0]['us_per_ray']):.2f}" if r["model"] == "int8" and other else ""
        same = {"yes": "yes", "NO": "**no**"}.get(r["same_picture"], "")
        body.append([r["model"], r["build"], r["us_per_ray"], ratio, r["kernels"], same, r["minutes"],
                     thousands(r["steps"]), run(r)])
    t = table(["<model", "<build", "µs/ray", "int8 / f32", "<kernels", "<same picture", "minutes", "steps", "<run"],
              body)
    return ("In a crate built without target flags", "plain-build", """`scripts/measure/plain_build_lego.sh
DATA_ROOT 10`: the default trained on lego at 100×100 and its int8 export,
rendered (the first view of the model's orbit, 100×100, one thread, early
termination 10⁻³, the faster of two) by `examples/quickstart`, a crate
that depends on `nerf-infer` as users' crates do, built with no target
flags (`plain`: the SIMD kernels chosen at run time) and with `-C
target-cpu=native` (`native`, as the workspace builds). "same picture":
the plain build's picture is byte for byte the native build's.""", t if rs else missing("plain-build"))


def block_sizes_section():
    rs = rows("block_sizes.csv")
    last = last_run(rs) if rs else []
    by = {(r["model"], r["block"]): r for r in last}
    body = []
    for r in sorted(last, key=lambda r: (r["model"] != "model", int(r["block"]))):
        one = by.get((r["model"], "1"))
        f32 = by.get(("model", r["block"]))
        vs_one = f"{float(r['us_per_ray']) / float(one['us_per_ray']):.2f}" if one else ""
        vs_f32 = f"{float(r['us_per_ray']) / float(f32['us_per_ray']):.2f}" if r["model"] == "int8" and f32 else ""
        same = {"yes": "yes", "NO": "**no**"}.get(r["same_picture"], "")
        body.append([r["model"], r["block"], r["us_per_ray"], vs_one, vs_f32, same, r["minutes"], thousands(r["steps"]),
                     run(r)])
    t = table(["<model", "block", "µs/ray", "/ block 1", "int8 / f32", "<same picture", "minutes", "steps", "<run"],
              body)
    return ("Samples per block", "plain-build", """The last run of `scripts/measure/plain_build_lego.sh`
also renders its two models with `examples/quickstart` built without
target flags, its scratch typed `AnyScratch<B>` for each block size B
(`scripts/measure/block_sizes.sh`: one thread, early termination 10⁻³, the fastest
of three). `nerf_infer::DEFAULT_BLOCK`, the block of `AnyScratch`,
`ScratchF32` and `ScratchFixed` when none is named, is 8 with `std` and 1
without. "same picture": byte for byte the picture of blocks of 1.""", t if rs else missing("plain-build"))


def duration(ns):
    return f"{ns / 1e6:.2f} ms" if ns >= 1e6 else f"{ns / 1e3:.2f} µs" if ns >= 1e3 else f"{ns:.1f} ns"


def bench_section():
    rs = latest(rows("bench.csv"), "group", "function")
    by = {(r["group"], r["function"]): r for r in rs}
    order = {"paper": 0, "fast": 1, "features": 2}
    nets = sorted((g.split("/", 1)[1] for g in dict.fromkeys(r["group"] for r in rs) if g.startswith("per_ray/")),
                  key=lambda n: (order.get(n, 3), n))
    body = []
    for net in nets:
        for unit in ("ray", "tile"):
            cells = []
            for path in ("f32", "int16", "int8"):
                r = by.get((f"per_{unit}/{net}", path))
                cells.append(f"{duration(float(r['ns_per_iter']))} "
                             f"({float(r['elements_per_iter']) / float(r['ns_per_iter']):.1f} GMAC/s)" if r else "")
            body.append([f"`{net}`, per {'ray' if unit == 'ray' else '8×8 tile'}"] + cells)
    t = table(["<network", "f32", "int16 weights", "int8 weights"], body)
    frame = [[f"`{r['function']}`", f"{float(r['ns_per_iter']) / 1e3 / float(r['elements_per_iter']):.2f}"]
             for r in rs if r["group"] == "frame/grid-model"]
    if frame:
        t += "\n\nA whole 32×32 view of the shipped grid model (µs per ray):\n\n" + table(["<model", "µs/ray"], frame)
    peak = [[f"`{r['function']}`", f"{float(r['elements_per_iter']) / float(r['ns_per_iter']):.1f}"]
            for r in rs if r["group"] == "peak"]
    if peak:
        t += "\n\nThe core's ceilings (GMAC/s):\n\n" + table(["<loop", "GMAC/s"], peak)
    step = [[f"`{r['function']}`", f"{float(r['ns_per_iter']) / 1e6:.1f}",
             f"{float(r['elements_per_iter']) / float(r['ns_per_iter']) * 1e9:,.0f}".replace(",", " ")]
            for r in rs if r["group"] == "train_step"]
    if step:
        t += "\n\nA training step (1024 rays, every core):\n\n" + table(["<preset", "ms/step", "rays/s"], step)
    prod = [[f"`{r['function']}`", f"{2 * float(r['elements_per_iter']) / float(r['ns_per_iter']):.1f}"]
            for r in sorted((r for r in rs if r["group"] == "gemm"), key=lambda r: int(r["function"].split("x")[0]))]
    if prod:
        t += ("\n\nThe gemm crate at the hidden layers' shapes (samples × outputs × inputs, one thread):\n\n"
              + table(["<product", "GFLOP/s"], prod))
    stamps = {}
    for r in rs:
        stamps.setdefault(run(r), []).append(r["group"].split("/")[0])
    if stamps:
        t += "\n\nRuns: " + "; ".join(f"{', '.join(f'`{g}`' for g in dict.fromkeys(gs))}: {st}"
                                     for st, gs in stamps.items()) + "."
    return ("Rendering and training cost", "bench", """`scripts/measure/bench.sh`: `cargo bench --bench per_ray`, `cargo
bench --bench peak` and `cargo bench --bench train_step` (criterion, the
mean time per iteration; one core but for the training step).
Per ray renders one ray and per tile an 8×8 tile through `render_tile`, for
random-weight networks (no early termination): `paper` is 8×256 with 64 +
128 samples, `fast` 4×64 with 48 + 48, `features` 2×64 behind the learned
feature grid with 192 samples (its MAC count leaves out the feature
lookups); GMAC/s is multiply-accumulates per second. The whole view is
the shipped grid model of the built-in scene with and without its
occupancy grid (`no-grid`) and early termination at 10⁻³ (`ert`). The
ceilings are register-only loops: f32 multiply + add, f32 FMA, and the
integer dot-product instruction (`vpdpwssd` with AVX-512 VNNI, `vpmaddwd`
with AVX2; the `avx2_` loops use 256-bit registers only). The training
step is one `Trainer::train_step` on the built-in scene at 64×64 after 200
warm-up steps; the products are the gemm crate's f32 kernel at the shapes
of the default's 64-wide hidden layers (2 flops per multiply-accumulate),
the ceiling to read the layers' GFLOP/s per thread from `nerf train`
against.""", t if rs else missing("bench"))


def train_step_section():
    rs = latest(rows("train_step.csv"), "preset")
    body = [[f"`{r['preset']}`", thousands(r["steps"]), f"**{r['ms_per_step']}**"]
            + [r[k] for k in ("grid", "draw", "chunks", "scatter", "adam", "sample", "encode", "forward", "composite",
                              "backward", "gflops_forward", "gflops_backward")] + [run(r)] for r in rs]
    t = table(["<preset", "steps", "ms/step", "grid", "draw", "chunks", "scatter", "Adam", "sample*", "encode*",
               "forward*", "composite*", "backward*", "GFLOP/s forward", "GFLOP/s backward", "<run"], body)
    return ("Where a training step's time goes", "step", """`scripts/measure/train_step.sh DATA_ROOT 3000 features grid`: `nerf train
--data lego --downscale 8 --iters 3000 --val-views 0 --log-every 3000
--preset P`, whose log line covers the whole run (`step_ms`,
`mlp_gflops_per_thread`; docs/CLI.md). Milliseconds per step: the
wall-clock stages one after the other (the occupancy grid's refresh, the
batch's draw, the chunks' forward and backward on every core, the feature
table's gradient scatter, Adam), then, starred, the chunks' thread time
summed over the threads (samples along the rays, the encoding: γ and the
feature lookups, the layers forward, the quadrature and loss, the backward
pass). GFLOP/s are the layers' per thread, 2 flops per multiply-accumulate
forward and 4 backward (from 2026-12-07 over the samples the backward
pass takes, which skips those whose gradient is zero, so earlier rows'
backward figures count more samples); the
gemm crate's own rate at these shapes is in the table above.""", t if rs else missing("step"))


def mesh_section():
    rs = sorted(latest(rows("mesh.csv"), "resolution"), key=lambda r: int(r["resolution"]))
    body = [[r["resolution"], r["model_psnr_val"], thousands(r["vertices"]), thousands(r["triangles"]), r["area"],
             r["volume"], "yes" if r["closed"] == "True" else "no", f"**{r['silhouette_iou_val']}**", r["seconds"],
             run(r)] for r in rs]
    t = table(["lattice", "model PSNR", "vertices", "triangles", "area", "volume", "<closed", "silhouette IoU",
               "seconds", "<run"], body)
    return ("A mesh of the density", "mesh", """`scripts/measure/mesh.sh DATA_ROOT`: the default trained 10 minutes on
lego at 100×100, then `nerf mesh --resolution N --masks lego --split val`
with the default threshold and floater removal: the mesh's size, area and
volume in scene units, whether it is closed, the IoU of its silhouette
against the alpha masks of the 10 validation views, and the seconds the
command took.""", t if rs else missing("mesh"))


def mcu_section():
    rs = latest(rows("mcu.csv"), "model", "board")
    body = [[r["model"], r["psnr_val"] or "", f"`{r['board']}`", thousands(r["model_bytes"]),
             thousands(r["flash_bytes"]), thousands(r["stack_bytes"]), f"{int(r['instr_per_ray']) / 1e6:.2f} M",
             f"{int(r['instr_min']) / 1e6:.2f}–{int(r['instr_max']) / 1e6:.2f} M", r["bit_exact"], run(r)]
            for r in rs]
    t = table(["<model", "PSNR", "<board", "model bytes", "flash bytes", "stack bytes", "instructions/ray",
               "range", "<bit-exact", "<run"], body)
    return ("On a Cortex-M", "mcu", """`scripts/measure/mcu.sh DATA_ROOT`: `examples/cortex-m/run` builds the
firmware for a Cortex-M3 (`lm3s6965evb`, no FPU, 256 KiB flash, 64 KiB RAM)
and a Cortex-M4F (`mps2-an386`), runs it under QEMU and renders an 8×8 tile
of a 64×64 view from a model in flash with the fixed-point path: the
shipped int8 and int16 models of the built-in scene (one firmware, both
models), and lego models trained 10 minutes at 100×100 and exported to
int8: the default, one with a 2¹¹-entry feature table, and one with a
2¹³-entry table stored as 4-bit codes (`nerf export --table-bits 4`)
(`run --model`; a board whose flash a model does not fit is left out;
`scripts/measure/mcu.sh DATA_ROOT RUN...` reruns some of them). PSNR is the int8
model's on lego's 10 validation views. Instructions are counted with
`-icount shift=0` and SysTick, calibrated on a loop of known length; flash
is the firmware image, models included; the stack high-water mark is
measured by painting the stack; bit-exact means every pixel equals the
host's render.""", t if rs else missing("mcu"))


def web_section():
    rs = latest(rows("web.csv"), "model")
    body = [[r["model"], r["browser"], r["crc_matches_host"], r["us_per_ray"], r["workers"], r["frame_ms_100"],
             r["frame_ms_100_one_thread"], r.get("orbit_fps_200") or "", run(r)] for r in rs]
    t = table(["<model", "<browser", "<same pixels as the host", "µs/ray", "workers", "100×100 frame (ms)",
               "on one thread (ms)", "200×200 orbit (frames/s)", "<run"], body)
    return ("In the browser", "web", """`scripts/measure/web.sh MODEL LABEL` for the shipped models of the built-in
scene (4×64, 48 + 96 samples, no grids) and `scripts/measure/web.sh --lego
DATA_ROOT` for the default trained 10 minutes on lego at 100×100 and
exported to int8: `nerf web` writes the viewer's page,
headless Chromium opens `index.html?check=1`, and the page reports the CRC-32
of the model's first orbit frame at 64×64 (compared with `nerf render
--orbit 1 --size 64`), µs per ray of that frame (no early termination, the
second of two renders), and the milliseconds of one 100×100 frame as the
viewer draws it (early termination at 10⁻³) over its Web Workers and on one
thread; the orbit: ten 200×200 frames drawn whole over the workers, one
after the other, as the view turns 0.05 rad a frame (`&orbit=10`), as the
viewer draws a view at rest (a moving view is drawn at the size its frame
budget allows, 50 ms, and scaled up).""", t if rs else missing("web"))


def paper_section():
    rs = latest(rows("paper_table.csv"), "scene", "minutes")
    body = [[r["scene"], f"{r['width']}×{r['height']}, {r['split']} ({r['views']} views)", f"{float(r['minutes']):.1f}",
             thousands(r["steps"]), f"**{float(r['psnr_f32']):.2f}**", f"{float(r['ssim_f32']):.3f}",
             f"{float(r['psnr_int8']):.2f}", f"{float(r['us_per_ray_f32']):.2f}", f"{float(r['us_per_ray_int8']):.2f}",
             f"{float(r['peak_mib']):.0f}", r["nerf_psnr"], r["nerf_ssim"], run(r)] for r in rs]
    t = table(["<scene", "<views", "minutes", "steps", "PSNR f32", "SSIM f32", "PSNR int8", "µs/ray f32",
               "µs/ray int8", "peak MiB", "NeRF PSNR", "NeRF SSIM", "<run"], body)
    plots = "".join(f"\n\n![{r['scene']}: PSNR against training minutes](paper_{r['scene']}.png)"
                    for r in latest(rs, "scene"))
    return ("The paper's protocol", "paper", """`scripts/measure/paper_table.sh SCENE MINUTES`: `nerf bench SCENE
--minutes MINUTES` with the default flags (synthetic scenes at full size on
white, forward-facing ones at 1/4 size with every 8th photo held out),
which trains the scene, exports it to int8 and scores both on every
held-out view (all threads, no early termination; µs per ray on one core
at early termination 10⁻³). NeRF: the 2020 paper's per-scene figure
(Mildenhall et al., supplementary Tables 4 and 5). The plot is the
bench's: validation PSNR on two held-out views against training minutes,
the scored PSNR last, the paper's figure dashed.""", (t + plots) if rs else missing("paper"))


def step_sizes_section():
    rs = latest(rows("step_sizes.csv"), "downscale", "config")
    base = {r["config"]: r for r in rs if r["downscale"] == "8"}
    body = []
    for r in rs:
        b = base.get("small")
        ratio = f"{float(r['rays_per_sec']) / float(b['rays_per_sec']):.2f}" if b and b["commit"] == r["commit"] else ""
        size = {"8": "100×100", "1": "800×800"}.get(r["downscale"], f"1/{r['downscale']}")
        what = {"default": "sized to the photos", "small": "the 100×100 configuration"}.get(r["config"], r["config"])
        body.append([size, what, thousands(r["rays_per_sec"]), ratio, r["samples_per_ray"], r["ms_per_step"], r["chunks"],
                     r["scatter"], r["adam"], r["grid"], r["draw"], r["peak_mib"], run(r)])
    t = table(["<photos", "<configuration", "rays/s", "× 100×100", "samples/ray", "ms/step", "chunks", "scatter", "Adam",
               "grid", "draw", "peak MiB", "<run"], body)
    return ("Training throughput against photo size", "step-sizes", """`scripts/measure/step_sizes.sh DATA_ROOT 1500 8 1`:
lego trained 1 500 steps at 100×100 and at 800×800, each with the default
flags (the feature grid and the samples per ray sized to the photos: at
800×800 a 2 048-cell finest level, 2¹⁸ entries per level, 16 levels
from e56e4a2 on and 8 before, and 512 stratified samples) and with the
configuration the 100×100 photos get (so that only the photos differ); rays per second, network samples per
ray and the step's wall-clock stages in ms over the last 500 steps, and
the run's peak memory. × 100×100: rays per second against the 100×100
run with the same configuration.""", t if rs else missing("step-sizes"))


SECTIONS = [default_section, full_section, paper_section, tradeoff_section, fast_int8_section, int8_section, table_bits_section, captures_section, proposal_section,
            proposal_samples_section, main_samples_section, room_region_section, seeds_section, ray_instructions_section, ray_stages_section, capture_ab_section, masks_section, plain_build_section, block_sizes_section, bench_section, train_step_section, step_sizes_section,
            mesh_section,
            mcu_section, web_section]


def anchor(title):
    """GitHub's id of a heading: lower case, letters (µ too), digits, spaces, hyphens and underscores kept."""
    return re.sub(r"[^\w -]", "", title.lower()).replace(" ", "-")


def readme_rows():
    """The README's headline rows: (what, figure, section title)."""
    out = []
    d = latest(rows("lego_default.csv"), "minutes", "seed")
    for minutes in ("10", "1"):
        rs = sorted((r for r in d if r["minutes"] == minutes), key=lambda r: r["seed"])
        if rs:
            seeds = " / ".join(r["seed"] for r in rs)
            out.append((f"lego 100×100, held-out views, the default after {minutes} min (seeds {seeds})",
                        f"{' / '.join(r['psnr_f32'] for r in rs)} dB f32, "
                        f"{' / '.join(r['psnr_int8'] for r in rs)} dB int8", "The default on lego"))
            if minutes == "10":
                out.append(("its int8 render, one core, early termination 10⁻³",
                            f"{' / '.join(r['us_int8'] for r in rs)} µs per ray "
                            f"({' / '.join(r['samples_int8'] for r in rs)} samples), "
                            f"{thousands(rs[0]['bytes_int8'])} B", "The default on lego"))
    paper = latest(rows("paper_table.csv"), "scene")
    for r in full_rows():
        # lego at full size through `nerf bench` (the paper's protocol, below) says the same
        if r["downscale"] == "1" and any(p["scene"] == "lego" and p["width"] == "800" for p in paper):
            continue
        out.append((f"lego {lego_size(r)}, held-out views, the default after {r['minutes']} min",
                    f"{r['psnr_f32']} dB f32, {r['psnr_int8']} dB int8 ({r['us_int8']} µs per ray)",
                    "The default at full resolution"))
    for r in paper:
        out.append((f"{r['scene']} {r['width']}×{r['height']}, the paper's protocol (`nerf bench`), the default after "
                    f"{float(r['minutes']):.0f} min", f"{float(r['psnr_f32']):.2f} dB f32, "
                    f"{float(r['psnr_int8']):.2f} dB int8 (NeRF 2020: {r['nerf_psnr']} dB)", "The paper's protocol"))
    fast = [r for r in fast_int8_rows() if float(r["psnr"]) >= 32.0]
    if fast:
        r = min(fast, key=lambda r: float(r["us_per_ray"]))
        out.append((f"lego 100×100 int8, the fastest render at ≥ 32 dB ({r['config']}, {r['coarse']} samples, "
                    f"early termination {r['early_stop']})", f"{r['us_per_ray']} µs per ray at {r['psnr']} dB",
                    "int8 toward 1 µs per ray"))
    q = latest(rows("int8_loss.csv"), "preset")
    if q:
        worst = max(abs(float(r["loss_db"])) for r in q)
        out.append((f"int8 against f32, every preset ({', '.join(r['preset'] for r in q)})",
                    f"within {worst:.2f} dB", "int8 against f32, every preset"))
    tb = {r["table_bits"]: r for r in latest(last_run(rows("table_bits.csv")), "table_bits")}
    if "16" in tb and "4" in tb:
        w, n = tb["16"], tb["4"]
        out.append((f"lego int8 with a 4-bit feature table ({n['minutes']} min at 100×100)",
                    f"{n['psnr']} dB ({float(n['psnr']) - float(w['psnr']):+.2f}), {thousands(n['bytes'])} B "
                    f"against {thousands(w['bytes'])}", "The feature table in 16, 8 and 4 bits"))
    c = {(r["capture"], r["treatment"]): r for r in latest(rows("captures.csv"), "capture", "treatment")}
    if ("bird", "features") in c and ("fox", "features") in c:
        b, f = c["bird", "features"], c["fox", "features"]
        out.append(("bird (COLMAP) / fox (instant-ngp), the default, 5 min at 1/8 size",
                    f"{b['psnr']} dB, SSIM {b['ssim']} / {f['psnr']} dB, {f['ssim']}", "Real captures"))
    p = {(r["capture"], r["treatment"]): r for r in latest(rows("proposal.csv"), "capture", "treatment")}
    if ("bird", "default") in p and ("fox", "default") in p:
        b, f = p["bird", "default"], p["fox", "default"]
        lg = p.get(("lego", "default"))
        lego_us = f" (lego {lg['us_per_ray_int8']} in the same run)" if lg and lg["commit"] == b["commit"] else ""
        out.append(("bird / fox with the proposal grid (`scripts/measure/proposal.sh`), 5 min at 1/8 size, rendered at the "
                    "model's default samples",
                    f"{b['psnr']} / {f['psnr']} dB f32, {b['psnr_int8']} / {f['psnr_int8']} dB int8 "
                    f"({thousands(b['steps'])} / {thousands(f['steps'])} steps), "
                    f"{b['us_per_ray_int8']} / {f['us_per_ray_int8']} µs per ray" + lego_us, "Real captures at the default"))
    ri = {r["capture"]: r for r in latest(rows("ray_instructions.csv"), "capture", "scheme") if r["scheme"] == "I8"}
    caps = [c for c in ("bird", "fox", "room") if f"{c} --fine 16" in ri]
    lg = ri.get("lego")
    if caps and lg and all(ri[f"{c} --fine 16"]["commit"] == lg["commit"] for c in caps):
        ratios = " / ".join(f"{int(ri[f'{c} --fine 16']['instructions_per_ray']) / int(lg['instructions_per_ray']):.2f}×"
                            for c in caps)
        psnr = " / ".join(f"{ri[f'{c} --fine 16']['psnr']} dB" for c in caps)
        out.append((f"{' / '.join(caps)} int8 at the render default with a proposal grid (16 network samples)",
                    f"{ratios} lego's instructions per ray, {psnr}", "Instructions per ray of the real captures"))
    m = [r for r in latest(rows("mesh.csv"), "resolution") if r["resolution"] == "256"]
    if m:
        out.append(("lego mesh, 256³ lattice", f"{'closed' if m[0]['closed'] == 'True' else 'open'}, silhouette IoU "
                    f"{m[0]['silhouette_iou_val']}", "A mesh of the density"))
    web = [r for r in latest(rows("web.csv"), "model") if "int8" in r["model"]]
    for r in [r for r in web if "lego" in r["model"]] or web:
        out.append((f"browser ({r['browser']}), {r['model']}, {r['workers']} workers",
                    f"100×100 frame in {r['frame_ms_100']} ms", "In the browser"))
    for r in latest(rows("mcu.csv"), "model", "board"):
        if r["board"] == "lm3s6965evb" and "int16" not in r["model"]:
            fig = f"{int(r['instr_per_ray']) / 1e6:.2f} M instructions per ray, {thousands(r['flash_bytes'])} B flash"
            if r["psnr_val"]:
                fig = f"{r['psnr_val']} dB, " + fig
            out.append((f"Cortex-M3, {r['model']}", fig, "On a Cortex-M"))
    return out


def main():
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    parts = ["""# Results

Written by `scripts/results.sh` from the CSV files beside this page; do not
edit by hand. `scripts/results.sh NAME...` reruns the named measurements
(appending rows to their CSV files) and rewrites this page and the README's
results table; `scripts/results.sh all` reruns every one, and
`scripts/results.sh --list` says how long each takes. Each table shows the
latest row for each of its keys, and each row the date, commit, CPU model
and core count of the run that measured it. The measurements on lego, bird
and fox read the public datasets from DATA_ROOT (`--data`, default
`../shared/data`). Timings were taken on shared machines: compare rows of
one run (same date and commit), not rows of different runs.
[EXPERIMENTS.md](EXPERIMENTS.md) has the measurements behind the design
choices (ablations), each with its command.
"""]
    index = []
    for f in SECTIONS:
        title, name, what, body = f()
        index.append(f"| [{title}](#{anchor(title)}) | `{name}` |")
        parts.append(f"## {title}\n\n{what}\n\n{body}\n" if what else f"## {title}\n\n{body}\n")
    parts.insert(1, "| section | `scripts/results.sh` name |\n|---|---|\n" + "\n".join(index) + "\n")
    with open(os.path.join(DOCS, "RESULTS.md"), "w") as f:
        f.write("\n".join(parts))

    readme = os.path.join(ROOT, "README.md")
    text = open(readme).read()
    begin, end = "<!-- results:begin -->", "<!-- results:end -->"
    if begin in text and end in text:
        body = table(["<what", "<figure", "<section"],
                     [[w, fig, f"[{s}](docs/RESULTS.md#{anchor(s)})"] for w, fig, s in readme_rows()])
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        with open(readme, "w") as f:
            f.write(f"{head}{begin}\n{body}\n{end}{tail}")
    print(f"wrote docs/RESULTS.md (commit {commit}) and the README's results table", file=sys.stderr)


if __name__ == "__main__":
    main()
