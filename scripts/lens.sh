#!/usr/bin/env bash
# Lens distortion applied against ignored on the fox capture (instant-ngp,
# OpenCV k1 k2 p1 p2) at the same number of steps, so that the machine's
# load does not favour either: trains each for STEPS at 1/8 size and scores
# the held-out views. Appends rows to docs/captures.csv.
#
#   scripts/lens.sh [DATA_ROOT] [STEPS] [SEED]
set -euo pipefail
cd "$(dirname "$0")/.."
root=${1:-../shared/data}
steps=${2:-4000}
seed=${3:-0}
cargo build --release --quiet
bin=target/release/nerf
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
csv=docs/captures.csv
[ -f "$csv" ] || echo "date,commit,cpu,capture,treatment,minutes,steps,psnr,ssim" > "$csv"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//; s/,//g')
commit=$(git rev-parse --short HEAD)
for name in lens no-distortion; do
  flags=()
  [ "$name" = no-distortion ] && flags=(--ignore-distortion)
  out="$work/fox-$name"
  "$bin" train --data "$root/fox" --downscale 8 --iters "$steps" --seed "$seed" --out "$out" "${flags[@]}" >&2
  mins=$(tail -1 "$out/train.jsonl" | python3 -c 'import json,sys; print("%.1f" % (json.load(sys.stdin)["train_secs"] / 60))')
  "$bin" eval "$out/model.nerf" --data "$root/fox" --split val "${flags[@]}" > "$out/eval.json"
  python3 - "$out/eval.json" <<PY >> "$csv"
import json, sys
e = json.load(open(sys.argv[1]))
print("$(date -u +%F),$commit,$cpu,fox,$name (equal steps; seed $seed),$mins,$steps,%.2f,%.4f" % (e["psnr"], e["ssim"]))
PY
  tail -1 "$csv" >&2
done
