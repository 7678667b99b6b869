#!/usr/bin/env bash
# Where a training step's time goes on lego at 100x100: trains each PRESET
# (default: the default, `features`) for STEPS steps with the whole run in
# one line of train.jsonl (`--log-every STEPS`) and appends its breakdown
# to docs/train_step.csv: date, commit, CPU, cores, preset, steps, ms per
# step, the wall-clock stages in ms per step (grid refresh, batch draw,
# chunks, table scatter, Adam), the chunks' thread time in ms per step
# summed over threads (sampling, encoding, layers forward, quadrature and
# loss, backward), and the layers' GFLOP/s per thread forward and backward.
#
#   scripts/measure/train_step.sh [DATA_ROOT] [STEPS] [PRESET...]
set -euo pipefail
root=${1:-../shared/data}
steps=${2:-3000}
shift $(($# < 2 ? $# : 2))
presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(features)
. "$(dirname "$0")/../lib/lib.sh"
out=docs/train_step.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,preset,steps,ms_per_step,grid,draw,chunks,scatter,adam,\
sample,encode,forward,composite,backward,gflops_forward,gflops_backward" > "$out"
for p in "${presets[@]}"; do
  "$bin" train --data "$root/lego" --downscale 8 --iters "$steps" --val-views 0 --log-every "$steps" \
    --preset "$p" --out "$work/$p" >&2
  python3 - "$stamp" "$p" "$steps" "$work/$p/train.jsonl" >> "$out" <<'PY'
import json, sys
stamp, preset, steps, log = sys.argv[1:]
e = json.loads(open(log).read().splitlines()[-1])
assert e["step"] == int(steps), f"the last line is step {e['step']}, not {steps}"
t, g = e["step_ms"], e["mlp_gflops_per_thread"]
wall = ["grid", "draw", "chunks", "scatter", "adam"]
split = ["sample", "encode", "forward", "composite", "backward"]
cells = [f"{sum(t[k] for k in wall):.2f}"] + [f"{t[k]:.2f}" for k in wall + split]
print(",".join([stamp, preset, steps] + cells + [f"{g['forward']:.1f}", f"{g['backward']:.1f}"]))
PY
  tail -1 "$out" >&2
done
