#!/usr/bin/env bash
# The int8 render's time per ray against its PSNR, for configurations that
# trade accuracy for speed: each CONFIG (a name from the list below) is
# trained on lego at 1/8 size (100x100) for STEPS steps on one thread with
# seed 0 (so the models are the same on any machine; two at a time), exported
# to int8 (`nerf export --bits 8`) and, once every run has finished,
# evaluated on the 10 validation views on one core (the fastest of three
# renders per view) with early termination at 1e-3 and 1e-2, and at 1e-2
# with 160, 144 and 128 samples per ray instead of the trained 192. Appends one row per
# configuration and render to docs/fast_int8.csv: date, commit, CPU, cores,
# configuration, steps, early termination, samples per ray (stratified),
# PSNR, samples evaluated per ray, µs per ray, int8 bytes.
#
#   scripts/measure/fast_int8.sh [DATA_ROOT] [STEPS] [CONFIG...]
#
# DATA_ROOT holds lego/; STEPS defaults to 60000; CONFIG to every name:
#   default          the default configuration (the features preset)
#   2x32             32-wide layers, no pixel footprint
#   2x32-alpha0.1    the same, cells kept while a step is at least 10 % opaque
set -euo pipefail
root=${1:-../shared/data}
iters=${2:-60000}
shift $(($# < 2 ? $# : 2))
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(default 2x32 2x32-alpha0.1)
. "$(dirname "$0")/../lib/lib.sh"
config() {
  case $1 in
    default) echo '{}' ;;
    2x32) echo '{"width": 32, "view_width": 32, "footprint": false}' ;;
    2x32-alpha0.1) echo '{"width": 32, "view_width": 32, "footprint": false, "grid_alpha": 0.1}' ;;
    *) echo "unknown configuration $1 (default, 2x32, 2x32-alpha0.1)" >&2; exit 2 ;;
  esac
}
for n in "${names[@]}"; do config "$n" > "$work/$n.json"; done
out_csv=docs/fast_int8.csv
[ -f "$out_csv" ] ||
  echo "date,commit,cpu,cores,config,steps,early_stop,coarse,psnr,samples_per_ray,us_per_ray,bytes_int8" > "$out_csv"
train() {
  "$bin" train --data "$root/lego" --downscale 8 --iters "$iters" --threads 1 --val-views 0 --seed 0 \
    --config "$work/$1.json" --out "$work/$1" > "$work/$1.log" 2>&1
  "$bin" export "$work/$1/model.nerf" --bits 8 --out "$work/$1/int8.nerf" >> "$work/$1.log" 2>&1
}
# two runs at a time, one thread each
for ((i = 0; i < ${#names[@]}; i += 2)); do
  echo "== training ${names[*]:i:2}" >&2
  pids=()
  for n in "${names[@]:i:2}"; do
    (train "$n" || { echo "training $n failed:" >&2; cat "$work/$n.log" >&2; exit 1; }) &
    pids+=($!)
  done
  # both runs end before a failure stops the script (its scratch folder goes with it)
  failed=0
  for p in "${pids[@]}"; do wait "$p" || failed=1; done
  [ "$failed" = 0 ]
done
for n in "${names[@]}"; do
  for render in "1e-3 192" "1e-2 192" "1e-2 160" "1e-2 144" "1e-2 128"; do
    read -r ert coarse <<< "$render"
    "$bin" eval "$work/$n/int8.nerf" --data "$root/lego" --split val --threads 1 --repeat 3 \
      --early-stop "$ert" --coarse "$coarse" > "$work/eval.json"
    python3 - "$work/eval.json" "$n" "$iters" "$ert" "$coarse" "$stamp" >> "$out_csv" <<'PY'
import json, sys
path, name, steps, ert, coarse, stamp = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{name},{steps},{ert},{coarse},{e['psnr']:.3f},{e['samples_per_ray']:.2f},"
      f"{e['us_per_ray']:.3f},{e['model_bytes']}")
PY
    tail -1 "$out_csv" >&2
  done
done
