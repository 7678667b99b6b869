#!/usr/bin/env bash
# Real captures against lego, at the training default: each capture trained
# MINUTES with no flags but --data, --downscale 8 and --out (the built-in
# room at 64x64, as scripts/measure/scene360.sh makes it; the same scene on black,
# --scene object, for the room's region PSNR), scored on its held-out views
# in f32, exported with --bits 8 and rendered on one core with early
# termination 1e-3 (the fastest of three renders). With BASELINE=1 in the
# environment, bird and fox are trained once more without the proposal grid
# (--config '{"proposal_res": 0}'), the same minutes, back to back.
# Appends rows to docs/proposal.csv: date, commit, CPU, cores, capture,
# treatment, minutes, steps, ms per step (the run's wall time over its
# steps), PSNR f32, PSNR int8, network evaluations per ray and µs per ray
# of the int8 render; then, where valgrind is installed, counts the int8
# renders' instructions per ray (scripts/measure/ray_instructions.sh), and prints
# scripts/lib/region_psnr.py on the room.
#
#   scripts/measure/proposal.sh [DATA_ROOT] [MINUTES]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
minutes=${2:-5}
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/proposal.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,treatment,minutes,steps,ms_per_step,psnr,psnr_int8,\
evaluations_per_ray,us_per_ray_int8" > "$out_csv"
"$bin" scene --out "$work/scene" --size 64 >&2
run() { # name treatment data downscale flags...
  local name=$1 treatment=$2 data=$3 ds=$4; shift 4
  local out="$work/$name-${treatment// /_}"
  echo "== $name $treatment" >&2
  "$bin" train --data "$data" --downscale "$ds" --minutes "$minutes" --out "$out" "$@" >&2
  "$bin" eval "$out/model.nerf" --data "$data" --split val --save "$out/save" > "$out/eval.json"
  "$bin" export "$out/model.nerf" --bits 8 --out "$out/int8.nerf" >&2
  "$bin" eval "$out/int8.nerf" --data "$data" --split val --threads 1 --repeat 3 --early-stop 1e-3 \
    > "$out/int8.json"
  python3 - "$stamp" "$name" "$treatment" "$minutes" "$(steps "$out")" "$out" >> "$out_csv" <<'PY'
import json, sys
stamp, name, treatment, minutes, steps, out = sys.argv[1:]
f = json.load(open(f"{out}/eval.json"))
q = json.load(open(f"{out}/int8.json"))
ms = float(minutes) * 60000 / int(steps)
print(f"{stamp},{name},{treatment},{minutes},{steps},{ms:.1f},{f['psnr']:.2f},{q['psnr']:.2f},"
      f"{q['samples_per_ray']:.2f},{q['us_per_ray']:.2f}")
PY
  tail -1 "$out_csv" >&2
}
run bird default "$root/bird" 8
run fox default "$root/fox" 8
run lego default "$root/lego" 8
# the network's samples per ray at render time against PSNR and time (docs/proposal_samples.csv)
NERF_BIN="$bin" NERF_COMMIT="$commit" scripts/measure/proposal_samples.sh "$work/bird-default/int8.nerf" "$root/bird" bird
NERF_BIN="$bin" NERF_COMMIT="$commit" scripts/measure/proposal_samples.sh "$work/fox-default/int8.nerf" "$root/fox" fox
run room default "$work/scene/room" 1
run room-on-black "object" "$work/scene/colmap" 1 --scene object
if [ "${BASELINE:-0}" = 1 ]; then
  echo '{"proposal_res": 0}' > "$work/no_proposal.json"
  run bird "no proposal grid" "$root/bird" 8 --config "$work/no_proposal.json"
  run fox "no proposal grid" "$root/fox" 8 --config "$work/no_proposal.json"
fi
# instructions per ray of the int8 exports (docs/ray_instructions.csv), where valgrind is installed
if command -v valgrind >/dev/null; then
  while read -r name data ds; do
    scripts/measure/ray_instructions.sh "$name" "$work/$name-default/int8.nerf" "$data" "$ds"
  done <<EOF2
lego $root/lego 8
bird $root/bird 8
fox $root/fox 8
room $work/scene/room 1
EOF2
fi
python3 scripts/lib/region_psnr.py "$work/room-default/save" "$work/room-on-black-object/save" >&2
