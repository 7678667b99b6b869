#!/usr/bin/env bash
# One capture trained from several seeds, back to back: DATA_DIR (`room`
# or `llff`: the built-in room or forward-facing capture of `nerf scene
# --size 64`, at full size; any other folder at 1/8 size) trained STEPS
# steps at the default with each SEED, scored on its held-out views. A
# run whose field went dark shows in `dark_steps`: the logged steps (every
# step is logged) whose batch PSNR is 3 dB or more below the first
# step's, the colour of an empty field (the background) where the first
# step's fog was nearer the photos. Appends rows to docs/seeds.csv: date,
# commit, CPU, cores, capture, seed, steps, PSNR, SSIM, dark_steps.
#
#   scripts/measure/seeds.sh DATA_DIR STEPS SEED...
#   scripts/measure/seeds.sh room 1000 0 1 2 3 4 5 6 7
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '12,13p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
data=$1
case $data in room | llff) ;; *) data=$(realpath "$data") ;; esac
iters=$2
shift 2
. "$(dirname "$0")/../lib/lib.sh"
builtin_capture
out_csv=docs/seeds.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,seed,steps,psnr,ssim,dark_steps" > "$out_csv"
for seed in "$@"; do
  out="$work/run"
  rm -rf "$out"
  "$bin" train --data "$data" --downscale "$downscale" --iters "$iters" --seed "$seed" --log-every 1 --out "$out" >&2
  "$bin" eval "$out/model.nerf" --data "$data" --split val > "$out/eval.json"
  python3 - "$stamp" "$(basename "$data")" "$seed" "$iters" "$out" >> "$out_csv" <<'PY'
import json, sys
stamp, cap, seed, iters, out = sys.argv[1:]
e = json.load(open(f"{out}/eval.json"))
logged = [json.loads(l) for l in open(f"{out}/train.jsonl")]
psnr = [r["psnr"] for r in logged if "step" in r and "psnr" in r]
dark = sum(p <= psnr[0] - 3 for p in psnr)
print(f"{stamp},{cap},{seed},{iters},{e['psnr']:.2f},{e['ssim']:.4f},{dark}")
PY
  tail -1 "$out_csv" >&2
done
