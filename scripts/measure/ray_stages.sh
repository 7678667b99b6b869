#!/usr/bin/env bash
# Where a ray's work goes, by stage: callgrind (with its cache simulator)
# runs `nerf eval MODEL --data DATA --split val` at 1/DOWNSCALE (default
# 8), one thread, early termination 1e-3, counting `render_view` and what
# it calls; each function's own cost (inlined code counted where its
# source file says) is put in a stage: the feature grid (its corners'
# gathers and interpolation), the positional encoding, the network's
# layers, compositing, the march (samples, skipping, the proposal grid,
# bookkeeping) and memory fills. Per ray: instructions, first-level data
# cache misses (reads and writes) and last-level misses, with the stage's
# share of the instructions. The binary is built for x86-64-v3 (AVX2;
# valgrind cannot run AVX-512), or NERF_BIN_V3 names one; the cache is
# valgrind's model of this machine's (its sizes in the output), not the
# CPU's counters. Appends rows to docs/ray_stages.csv: date, commit, CPU,
# cores, capture, scheme, rays, stage, instructions per ray, share,
# D1 misses per ray, LL misses per ray.
#
#   scripts/measure/ray_stages.sh CAPTURE MODEL DATA [DOWNSCALE]
set -euo pipefail
name=$1
model=$(realpath "$2")
data=$(realpath "$3")
ds=${4:-8}
given_v3=${NERF_BIN_V3:+$(realpath "$NERF_BIN_V3")}
. "$(dirname "$0")/../lib/lib.sh"
valgrind_bin
out_csv=docs/ray_stages.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,scheme,rays,stage,instructions_per_ray,share,\
d1_misses_per_ray,ll_misses_per_ray" > "$out_csv"
valgrind --tool=callgrind --cache-sim=yes --callgrind-out-file="$work/eval.cg" --toggle-collect='*render_view*' \
  "$bin" eval "$model" --data "$data" --split val --downscale "$ds" --threads 1 --early-stop 1e-3 \
  > "$work/eval.json" 2>/dev/null
callgrind_annotate --inclusive=no --threshold=100 --auto=no "$work/eval.cg" 2>/dev/null > "$work/self.txt"
python3 - "$stamp" "$name" "$work/eval.json" "$work/self.txt" >> "$out_csv" <<'PY'
import json, re, sys
stamp, name, eval_path, self_path = sys.argv[1:]
e = json.load(open(eval_path))
rays = e["rays"]
STAGES = ["feature grid", "positional encoding", "network", "compositing", "march", "memory fills", "other"]

def stage(path, func):
    """The stage of a function's own cost, from its source file (inlined code keeps its file), else its name."""
    f = path.lower()
    if "memset" in f or "memcpy" in f or "memmove" in f:
        return "memory fills"
    if "/features" in f or "features.rs" in f:
        return "feature grid"
    if "encoding.rs" in f:
        return "positional encoding"
    if "composite" in f:
        return "compositing"
    if "/layer" in f or "/network/" in f or "vnni" in f or "kernel" in f:
        return "network"
    if any(k in f for k in ("march", "sampling", "occupancy", "proposal", "unbounded", "camera", "/render/")):
        return "march"
    # the standard library's and the intrinsics' code, inlined: the function it sits in
    if "encode_rows" in func or "feature" in func:
        return "feature grid"
    if "encode" in func:
        return "positional encoding"
    if any(k in func for k in ("layer", "requant", "head", "dense", "network")):
        return "network"
    if "composite" in func:
        return "compositing"
    if any(k in func for k in ("march", "render", "sampling", "occupancy", "proposal")):
        return "march"
    return "other"

# one cell per event, "N (x%)", "N" or ".", then file:function
cell = re.compile(r"\s*(?:([\d,]+)(?: \(\s*[\d.]+%\))?|(\.))(?=\s)")
events, totals = None, None
for line in open(self_path):
    if line.startswith("Events recorded:"):
        events = line.split(":", 1)[1].split()
        totals = {s: [0] * len(events) for s in STAGES}
    if events is None or "PROGRAM TOTALS" in line:
        continue
    pos, values = 0, []
    while len(values) < len(events):
        m = cell.match(line, pos)
        if not m:
            break
        values.append(int(m.group(1).replace(",", "")) if m.group(1) else 0)
        pos = m.end()
    if len(values) < len(events) or not values:
        continue
    where = line[pos:].strip()
    if ":" not in where:
        continue
    path, _, func = where.partition(":")
    func = func.split(" [")[0]
    row = totals[stage(path, func)]
    for i, v in enumerate(values):
        row[i] += v
ir = sum(t[events.index("Ir")] for t in totals.values())
d1 = lambda t: t[events.index("D1mr")] + t[events.index("D1mw")]
ll = lambda t: t[events.index("DLmr")] + t[events.index("DLmw")]
for s in STAGES:
    t = totals[s]
    if t[events.index("Ir")] == 0:
        continue
    print(f"{stamp},{name},{e['scheme']},{rays},{s},{t[events.index('Ir')] / rays:.0f},"
          f"{t[events.index('Ir')] / ir:.3f},{d1(t) / rays:.1f},{ll(t) / rays:.2f}")
PY
tail -n 7 "$out_csv" >&2
