#!/usr/bin/env bash
# Trains on real captures with no flags but --data, --out, --downscale,
# --minutes and --preset (plus the treatment compared), then scores the held-out views
# (every 8th image) with `nerf eval`. Appends one CSV row per run to
# docs/captures.csv: date, commit, CPU, capture, treatment, minutes, steps,
# PSNR, SSIM.
#
#   scripts/measure/captures.sh [DATA_ROOT] [MINUTES] [ONLY]
#
# DATA_ROOT holds bird/ (COLMAP) and fox/ (instant-ngp); default ../shared/data.
# ONLY, a grep pattern on "CAPTURE TREATMENT" (e.g. 'bird auto'), selects runs.
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-5}
only=${3:-.}
. "$(dirname "$0")/../lib/lib.sh"
run() { # capture treatment flags...
  local cap=$1 name=$2; shift 2
  echo "$cap $name" | grep -q -- "$only" || return 0
  local out="$work/$cap-$name"
  echo "== $cap $name: $*" >&2
  "$bin" train --data "$root/$cap" --downscale 8 --minutes "$minutes" --out "$out" "$@" >&2
  # eval takes the loading flags; --preset is for training only
  local eval_flags=() skip=0 f
  for f in "$@"; do
    if [ "$skip" = 1 ]; then skip=0; elif [ "$f" = --preset ]; then skip=1; else eval_flags+=("$f"); fi
  done
  "$bin" eval "$out/model.nerf" --data "$root/$cap" --split val "${eval_flags[@]}" > "$out/eval.json"
  record "$cap" "$name" "$minutes" "$(steps "$out")" "$out/eval.json"
}
# the treatments compared on the fast preset, then the default (features)
run bird auto --preset fast
run bird object --scene object --preset fast
run fox auto --preset fast
run fox object --scene object --preset fast
run fox no-distortion --ignore-distortion --preset fast
run bird features --preset features
run fox features --preset features
