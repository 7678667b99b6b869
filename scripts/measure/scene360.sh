#!/usr/bin/env bash
# The built-in scene as a 360° COLMAP capture with and without its coloured
# room: trains each for MINUTES with PRESET (default: the training default;
# the room capture gets the default unbounded treatment, the one on black
# the object box, `--scene object`) and scores the held-out views. Appends
# rows to docs/captures.csv (treatment: "object" or "auto", then the preset
# when one is given).
#
#   scripts/measure/scene360.sh [MINUTES] [PRESET]
set -euo pipefail
minutes=${1:-2}
preset=${2:-}
. "$(dirname "$0")/../lib/lib.sh"
"$bin" scene --out "$work/scene" --size 64 >&2
for pair in "colmap object --scene object" "room auto"; do
  set -- $pair
  cap=$1 name=$2; shift 2
  out="$work/$cap-$name"
  "$bin" train --data "$work/scene/$cap" --minutes "$minutes" --out "$out" ${preset:+--preset "$preset"} "$@" >&2
  "$bin" eval "$out/model.nerf" --data "$work/scene/$cap" --split val "$@" > "$out/eval.json"
  record "scene-$cap" "$name${preset:+ $preset}" "$minutes" "$(steps "$out")" "$out/eval.json"
done
