#!/usr/bin/env bash
# Trains on real captures with no flags but --data, --out, --downscale and
# --minutes (plus the treatment compared), then scores the held-out views
# (every 8th image) with `nerf eval`. Appends one CSV row per run to
# docs/captures.csv: date, commit, CPU, capture, treatment, minutes, steps,
# PSNR, SSIM.
#
#   scripts/captures.sh [DATA_ROOT] [MINUTES]
#
# DATA_ROOT holds bird/ (COLMAP) and fox/ (instant-ngp); default ../shared/data.
set -euo pipefail
cd "$(dirname "$0")/.."
root=${1:-../shared/data}
minutes=${2:-5}
cargo build --release --quiet
bin=target/release/nerf
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
csv=docs/captures.csv
[ -f "$csv" ] || echo "date,commit,cpu,capture,treatment,minutes,steps,psnr,ssim" > "$csv"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//; s/,//g')
commit=$(git rev-parse --short HEAD)
run() { # capture treatment flags...
  local cap=$1 name=$2; shift 2
  local out="$work/$cap-$name"
  echo "== $cap $name: $*" >&2
  "$bin" train --data "$root/$cap" --downscale 8 --minutes "$minutes" --out "$out" "$@" >&2
  local steps
  steps=$("$bin" info "$out/model.nerf" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["trained"]["iterations"])')
  "$bin" eval "$out/model.nerf" --data "$root/$cap" --split val "$@" > "$out/eval.json"
  python3 - "$out/eval.json" <<PY >> "$csv"
import json, sys
e = json.load(open(sys.argv[1]))
print("$(date -u +%F),$commit,$cpu,$cap,$name,$minutes,$steps,%.2f,%.4f" % (e["psnr"], e["ssim"]))
PY
  tail -1 "$csv" >&2
}
run bird auto
run bird object --scene object
run fox auto
run fox object --scene object
run fox no-distortion --ignore-distortion
