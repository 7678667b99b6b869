#!/usr/bin/env bash
# Lens distortion on the fox capture (instant-ngp, OpenCV k1 k2 p1 p2) at
# the same number of steps, so that the machine's load favours none:
# rays bent through the lens, photos undistorted once at load
# (`--undistort`), and the lens ignored (`--ignore-distortion`). Trains each
# for STEPS at 1/8 size with PRESET (default: the training default) and
# scores the held-out photos as taken (rays through the lens; ignoring it
# for the model trained so), and the undistorted model also against its
# resampled photos. Appends rows to docs/captures.csv.
#
#   scripts/measure/lens.sh [DATA_ROOT] [STEPS] [SEED] [PRESET]
set -euo pipefail
root=${1:-../shared/data}
steps=${2:-4000}
seed=${3:-0}
preset=${4:-}
. "$(dirname "$0")/../lib/lib.sh"
for name in lens undistort no-distortion; do
  flags=()
  [ "$name" = undistort ] && flags=(--undistort)
  [ "$name" = no-distortion ] && flags=(--ignore-distortion)
  out="$work/fox-$name"
  # every step logged, so the last line holds the training time whatever STEPS is
  "$bin" train --data "$root/fox" --downscale 8 --iters "$steps" --seed "$seed" --log-every 1 \
    ${preset:+--preset "$preset"} --out "$out" "${flags[@]}" >&2
  mins=$(tail -1 "$out/train.jsonl" | python3 -c 'import json,sys; print("%.1f" % (json.load(sys.stdin)["train_secs"] / 60))')
  label="$name (equal steps; seed $seed${preset:+; $preset})"
  if [ "$name" = undistort ]; then
    "$bin" eval "$out/model.nerf" --data "$root/fox" --split val > "$out/eval.json"
    record fox "$label" "$mins" "$steps" "$out/eval.json"
    "$bin" eval "$out/model.nerf" --data "$root/fox" --split val --undistort > "$out/eval_resampled.json"
    record fox "$label; scored on undistorted photos" "$mins" "$steps" "$out/eval_resampled.json"
  else
    "$bin" eval "$out/model.nerf" --data "$root/fox" --split val "${flags[@]}" > "$out/eval.json"
    record fox "$label" "$mins" "$steps" "$out/eval.json"
  fi
done
