#!/usr/bin/env bash
# Lens distortion applied against ignored on the fox capture (instant-ngp,
# OpenCV k1 k2 p1 p2) at the same number of steps, so that the machine's
# load does not favour either: trains each for STEPS at 1/8 size (fast preset) and scores
# the held-out views. Appends rows to docs/captures.csv.
#
#   scripts/lens.sh [DATA_ROOT] [STEPS] [SEED]
set -euo pipefail
root=${1:-../shared/data}
steps=${2:-4000}
seed=${3:-0}
. "$(dirname "$0")/lib.sh"
for name in lens no-distortion; do
  flags=()
  [ "$name" = no-distortion ] && flags=(--ignore-distortion)
  out="$work/fox-$name"
  # every step logged, so the last line holds the training time whatever STEPS is
  "$bin" train --data "$root/fox" --downscale 8 --iters "$steps" --seed "$seed" --log-every 1 --preset fast \
    --out "$out" "${flags[@]}" >&2
  mins=$(tail -1 "$out/train.jsonl" | python3 -c 'import json,sys; print("%.1f" % (json.load(sys.stdin)["train_secs"] / 60))')
  "$bin" eval "$out/model.nerf" --data "$root/fox" --split val "${flags[@]}" > "$out/eval.json"
  record fox "$name (equal steps; seed $seed)" "$mins" "$steps" "$out/eval.json"
done
