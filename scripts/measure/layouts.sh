#!/usr/bin/env bash
# Trains the bird capture from its COLMAP folder and from the same cameras
# written in the other layouts `nerf train` reads: LLFF's poses_bounds.npy
# (as LLFF's imgs2poses writes it, by the colmap_to_llff example), and
# nerfstudio's transforms.json without sparse points (as instant-ngp's
# colmap2nerf writes it) and with them (ply_file_path, as ns-process-data
# writes it; both by the colmap_to_transforms example). Each layout trains
# the same number of steps on one thread (two runs side by side, seed 0)
# and is scored on its held-out views (every 8th image) with `nerf eval`.
# Appends one row per layout to docs/captures.csv and prints each model's
# fitted box and near plane.
#
#   scripts/measure/layouts.sh [DATA_ROOT] [STEPS]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
steps_n=${2:-1500}
. "$(dirname "$0")/../lib/lib.sh"
cargo build --release --quiet -p nerf-train --example colmap_to_llff --example colmap_to_transforms
target/release/examples/colmap_to_llff "$root/bird" "$work/bird_llff"
target/release/examples/colmap_to_transforms "$root/bird" "$work/bird_ngp"
target/release/examples/colmap_to_transforms "$root/bird" "$work/bird_ns" --points
side_by_side "$steps_n" colmap "$root/bird" llff "$work/bird_llff"
side_by_side "$steps_n" ngp "$work/bird_ngp" ns "$work/bird_ns"
for name in colmap llff ngp ns; do
  "$bin" info "$work/$name/model.nerf" --json | python3 -c '
import json, sys
s = json.load(sys.stdin)["scene"]
print(sys.argv[1], "box", [round(v, 3) for v in s["bounds_min"]], [round(v, 3) for v in s["bounds_max"]],
      "near", round(s["near"], 3), file=sys.stderr)' "$name"
done
how="(equal steps; seed 0; one thread)"
record bird "colmap layout $how" "-" "$(steps "$work/colmap")" "$work/colmap/eval.json"
record bird "llff layout $how" "-" "$(steps "$work/llff")" "$work/llff/eval.json"
record bird "transforms.json layout without points $how" "-" "$(steps "$work/ngp")" "$work/ngp/eval.json"
record bird "transforms.json layout with points $how" "-" "$(steps "$work/ns")" "$work/ns/eval.json"
