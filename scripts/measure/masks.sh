#!/usr/bin/env bash
# What masks buy on a capture with something moving through its photos:
# scripts/lib/occluders.py paints a rectangle of a random colour over a tenth
# of every training photo of an instant-ngp or COLMAP capture (held-out
# photos untouched), and the capture is trained as it is, painted, and
# painted with masks that leave the rectangles out (nerfstudio's mask_path
# in transforms.json, a masks/ folder beside a COLMAP capture's images/),
# each for ITERS steps at 1/8 size (seed 0, default flags), then scored on
# its held-out views. Appends rows to
# docs/masks.csv: date, commit, CPU, cores, capture, copy, steps, seconds
# of training, PSNR, SSIM. Needs Pillow (pip install pillow).
#
#   scripts/measure/masks.sh DATA_DIR ITERS
#   scripts/measure/masks.sh ../shared/data/fox 2000
#   scripts/measure/masks.sh ../shared/data/bird 2000
set -euo pipefail
data=$(realpath "$1")
iters=$2
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/masks.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,copy,steps,train_seconds,psnr,ssim" > "$out_csv"
python3 scripts/lib/occluders.py "$data" "$work/copies"
for copy in clean painted masked; do
  run="$work/run_$copy"
  start=$(date +%s.%N)
  "$bin" train --data "$work/copies/$copy" --downscale 8 --iters "$iters" --seed 0 --out "$run" >&2
  end=$(date +%s.%N)
  "$bin" eval "$run/model.nerf" --data "$work/copies/$copy" --split val > "$run/eval.json"
  python3 - "$stamp" "$(basename "$data")" "$copy" "$iters" "$start" "$end" "$run/eval.json" >> "$out_csv" <<'PY'
import json, sys
stamp, cap, copy, iters, start, end, path = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{cap},{copy},{iters},{float(end) - float(start):.0f},{e['psnr']:.2f},{e['ssim']:.4f}")
PY
  tail -1 "$out_csv" >&2
done
