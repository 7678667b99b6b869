#!/usr/bin/env bash
# Trains the bird capture from its COLMAP folder and from the same capture
# written in LLFF's layout (poses_bounds.npy as LLFF's imgs2poses writes it,
# by the colmap_to_llff example), the same number of steps on one thread
# each (the two runs side by side, seed 0), and scores the held-out views
# (every 8th image) with `nerf eval`. Appends one row per layout to
# docs/captures.csv.
#
#   scripts/llff_layout.sh [DATA_ROOT] [STEPS]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
steps_n=${2:-1500}
. "$(dirname "$0")/lib.sh"
cargo build --release --quiet -p nerf-train --example colmap_to_llff
target/release/examples/colmap_to_llff "$root/bird" "$work/bird_llff"
train() { # name data
  "$bin" train --data "$2" --downscale 8 --iters "$steps_n" --threads 1 --seed 0 --out "$work/$1" > "$work/$1.log" 2>&1
  "$bin" eval "$work/$1/model.nerf" --data "$2" --split val --threads 1 > "$work/$1/eval.json"
}
train colmap "$root/bird" &
train llff "$work/bird_llff" &
wait %1 || { cat "$work/colmap.log" >&2; exit 1; }
wait %2 || { cat "$work/llff.log" >&2; exit 1; }
grep -h "scene\|unbounded\|forward" "$work/colmap.log" "$work/llff.log" >&2 || true
record bird "colmap layout (equal steps; seed 0; one thread)" "-" "$(steps "$work/colmap")" "$work/colmap/eval.json"
record bird "llff layout (equal steps; seed 0; one thread)" "-" "$(steps "$work/llff")" "$work/llff/eval.json"
