#!/usr/bin/env bash
# The built-in room's object against the same object on black, back to back:
# `nerf scene --size 64`, the scene on black trained MINUTES with
# `--scene object` and no other flag, then the room trained MINUTES with
# each configuration (the default with the configuration's fields on top,
# as `--config` takes them), every model scored on the held-out views
# rendered as the model says (`nerf eval --save`) and split by
# scripts/region_psnr.py into the object's pixels (those not black in the
# view on black) and the rest. Appends rows to docs/room_region.csv:
# date, commit, CPU, cores, capture (room, or on-black), configuration,
# minutes, steps, PSNR (the mean over views, as `nerf eval`), the pooled
# PSNR of the object's pixels, of the rest, and of every pixel.
#
#   scripts/room_region.sh MINUTES CONFIG_JSON...
#   scripts/room_region.sh 5 '{}' '{"feature_max_res": 1024}'
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '14,15p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
minutes=$1
shift
. "$(dirname "$0")/lib.sh"
out_csv=docs/room_region.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,configuration,minutes,steps,psnr,object_psnr,rest_psnr,all_psnr" \
  > "$out_csv"
"$bin" scene --out "$work/scene" --size 64 >&2
# run NAME DATA CONFIG_JSON FLAGS...: trains, saves the held-out renders, prints the eval JSON's path
run() {
  local name=$1 data=$2 config=$3; shift 3
  local out="$work/$name"
  mkdir -p "$out"
  echo "$config" > "$out/config.json"
  echo "== $name $config" >&2
  "$bin" train --data "$data" --minutes "$minutes" --out "$out" --config "$out/config.json" "$@" >&2
  "$bin" eval "$out/model.nerf" --data "$data" --split val --save "$out/save" "$@" > "$out/eval.json"
}
# row CAPTURE CONFIG RUN_DIR: appends the run's row, its regions scored against the view on black
row() {
  python3 scripts/region_psnr.py "$3/save" "$work/on-black/save" > "$3/regions.txt"
  python3 - "$stamp" "$1" "$2" "$minutes" "$(steps "$3")" "$3" >> "$out_csv" <<'PY'
import json, re, sys
stamp, cap, config, minutes, steps, out = sys.argv[1:]
e = json.load(open(f"{out}/eval.json"))
text = open(f"{out}/regions.txt").read()
db = {r: re.search(rf"all views, {r}: (\S+) dB", text).group(1) for r in ("object", "rest", "every pixel")}
config = '"' + config.replace('"', "'") + '"'
print(f"{stamp},{cap},{config},{minutes},{steps},{e['psnr']:.2f},{db['object']},{db['rest']},{db['every pixel']}")
PY
  tail -1 "$out_csv" >&2
}
run on-black "$work/scene/colmap" '{}' --scene object
row on-black '{}' "$work/on-black"
k=0
for config in "$@"; do
  run "room-$k" "$work/scene/room" "$config"
  row room "$config" "$work/room-$k"
  k=$((k + 1))
done
