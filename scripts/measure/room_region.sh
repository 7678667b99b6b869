#!/usr/bin/env bash
# The built-in room's object against the same object on black, back to back:
# `nerf scene --size 64`, then for each seed the scene on black trained
# LENGTH with `--scene object` and no other flag, and the room trained
# LENGTH with each configuration (the default with the configuration's
# fields on top, as `--config` takes them; a configuration that starts
# with `-` is a flag of `nerf train` instead), every model scored on the
# held-out views rendered as the model says (`nerf eval --save`) and split
# by scripts/lib/region_psnr.py into the object's pixels (those not black in
# the view on black) and the rest. LENGTH is a number of steps, or with an
# m suffix that many minutes; SEEDS a comma-separated list. Appends rows to
# docs/room_region.csv: date, commit, CPU, cores, capture (room, or
# on-black), configuration, minutes (empty for a fixed number of steps),
# steps, PSNR (the mean over views, as `nerf eval`), the pooled PSNR of the
# object's pixels, of the rest, and of every pixel, and the seed.
#
#   scripts/measure/room_region.sh LENGTH SEEDS CONFIG_JSON...
#   scripts/measure/room_region.sh 5m 0 '{}' '{"feature_max_res": 1024}'
#   scripts/measure/room_region.sh 2000 0,1,2,3 '{}' '--preset fast'
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '17,19p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
length=$1
case $length in
  *m) budget=(--minutes "${length%m}") minutes=${length%m} ;;
  *) budget=(--iters "$length") minutes= ;;
esac
IFS=, read -r -a seeds <<< "$2"
shift 2
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/room_region.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,configuration,minutes,steps,psnr,object_psnr,rest_psnr,all_psnr,seed" \
  > "$out_csv"
"$bin" scene --out "$work/scene" --size 64 >&2
# run NAME DATA CONFIG SEED FLAGS...: trains and saves the held-out renders ($work/NAME)
run() {
  local name=$1 data=$2 config=$3 seed=$4; shift 4
  local out="$work/$name" flags=()
  mkdir -p "$out"
  case $config in
    -*) read -r -a flags <<< "$config"; echo '{}' > "$out/config.json" ;;
    *) echo "$config" > "$out/config.json" ;;
  esac
  echo "== $name $config" >&2
  "$bin" train --data "$data" "${budget[@]}" --seed "$seed" --out "$out" --config "$out/config.json" "${flags[@]}" "$@" >&2
  "$bin" eval "$out/model.nerf" --data "$data" --split val --save "$out/save" "$@" > "$out/eval.json"
}
# row CAPTURE CONFIG RUN_DIR SEED: appends the run's row, its regions scored against the seed's view on black
row() {
  python3 scripts/lib/region_psnr.py "$3/save" "$work/on-black-$4/save" > "$3/regions.txt"
  python3 - "$stamp" "$1" "$2" "$minutes" "$(steps "$3")" "$3" "$4" >> "$out_csv" <<'PY'
import json, re, sys
stamp, cap, config, minutes, steps, out, seed = sys.argv[1:]
e = json.load(open(f"{out}/eval.json"))
text = open(f"{out}/regions.txt").read()
db = {r: re.search(rf"all views, {r}: (\S+) dB", text).group(1) for r in ("object", "rest", "every pixel")}
config = '"' + config.replace('"', "'") + '"'
print(f"{stamp},{cap},{config},{minutes},{steps},{e['psnr']:.2f},{db['object']},{db['rest']},{db['every pixel']},{seed}")
PY
  tail -1 "$out_csv" >&2
}
for seed in "${seeds[@]}"; do
  run "on-black-$seed" "$work/scene/colmap" '{}' "$seed" --scene object
  row on-black '{}' "$work/on-black-$seed" "$seed"
  k=0
  for config in "$@"; do
    run "room-$k-$seed" "$work/scene/room" "$config" "$seed"
    row room "$config" "$work/room-$k-$seed" "$seed"
    k=$((k + 1))
  done
done
