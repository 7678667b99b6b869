#!/usr/bin/env bash
# The built-in scene as a 360° COLMAP capture with and without its coloured
# room: trains each for MINUTES with default flags (the room capture gets the
# default unbounded box; the one on black the object box, `--scene object`)
# and scores the held-out views. Appends rows to docs/captures.csv.
#
#   scripts/scene360.sh [MINUTES]
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-2}
cargo build --release --quiet
bin=target/release/nerf
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
csv=docs/captures.csv
[ -f "$csv" ] || echo "date,commit,cpu,capture,treatment,minutes,steps,psnr,ssim" > "$csv"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//; s/,//g')
commit=$(git rev-parse --short HEAD)
"$bin" scene --out "$work/scene" --size 64 >&2
for pair in "colmap object --scene object" "room auto"; do
  set -- $pair
  cap=$1 name=$2; shift 2
  out="$work/$cap-$name"
  "$bin" train --data "$work/scene/$cap" --minutes "$minutes" --out "$out" "$@" >&2
  steps=$("$bin" info "$out/model.nerf" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["trained"]["iterations"])')
  "$bin" eval "$out/model.nerf" --data "$work/scene/$cap" --split val "$@" > "$out/eval.json"
  python3 - "$out/eval.json" <<PY >> "$csv"
import json, sys
e = json.load(open(sys.argv[1]))
print("$(date -u +%F),$commit,$cpu,scene-$cap,$name,$minutes,$steps,%.2f,%.4f" % (e["psnr"], e["ssim"]))
PY
  tail -1 "$csv" >&2
done
