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
side_by_side "$steps_n" colmap "$root/bird" llff "$work/bird_llff"
grep -h "scene\|unbounded\|forward" "$work/colmap.log" "$work/llff.log" >&2 || true
record bird "colmap layout (equal steps; seed 0; one thread)" "-" "$(steps "$work/colmap")" "$work/colmap/eval.json"
record bird "llff layout (equal steps; seed 0; one thread)" "-" "$(steps "$work/llff")" "$work/llff/eval.json"
