#!/usr/bin/env bash
# Runs `nerf capture` on every photo of the bird capture (COLMAP on the CPU),
# then trains the capture it makes and the capture as shipped (its own
# sparse/0) the same number of steps on one thread each (the two runs side
# by side, seed 0), and scores the held-out views (every 8th photo) with
# `nerf eval`. Prints the capture's stage times; appends one row per
# capture to docs/captures.csv.
#
#   scripts/measure/capture_bird.sh [DATA_ROOT] [STEPS]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
steps_n=${2:-1500}
. "$(dirname "$0")/../lib/lib.sh"
"$bin" capture --photos "$root/bird/images" --out "$work/bird_capture" 2>&1 | tee "$work/capture.log" >&2
side_by_side "$steps_n" shipped "$root/bird" captured "$work/bird_capture"
record bird "shipped sparse/0 (equal steps; seed 0; one thread)" "-" "$(steps "$work/shipped")" "$work/shipped/eval.json"
record bird "nerf capture's reconstruction (equal steps; seed 0; one thread)" "-" "$(steps "$work/captured")" "$work/captured/eval.json"
