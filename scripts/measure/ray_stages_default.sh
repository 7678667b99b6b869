#!/usr/bin/env bash
# The default trained MINUTES (default 3) on lego and bird at 1/8 size
# (seed 0, no validation), each exported to int8, then
# scripts/measure/ray_stages.sh on the four models: where a ray's work goes, by
# stage, in docs/ray_stages.csv.
#
#   scripts/measure/ray_stages_default.sh [DATA_ROOT] [MINUTES]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
minutes=${2:-3}
. "$(dirname "$0")/../lib/lib.sh"
for capture in lego bird; do
  run="$work/$capture"
  "$bin" train --data "$root/$capture" --downscale 8 --minutes "$minutes" --val-views 0 --seed 0 --out "$run" >&2
  "$bin" export "$run/model.nerf" --bits 8 --out "$run/int8.nerf" >&2
  for m in int8 model; do
    scripts/measure/ray_stages.sh "$capture" "$run/$m.nerf" "$root/$capture" 8
  done
done
