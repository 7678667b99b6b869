#!/usr/bin/env bash
# Configurations compared on one capture, back to back: the capture
# trained LENGTH at 1/8 size (DATA_DIR `room` or `llff`: the built-in
# room or forward-facing capture of `nerf scene --size 64`, at full
# size; ITERS steps, or with an m suffix
# that many minutes; seed 0, the default with each configuration's
# fields on top, as `--config` takes them), scored on its
# held-out views in f32 at the field's own colour and with a per-photo
# colour correction fitted on the left half of each view and scored on
# the right half (scripts/lib/appearance_half.py), exported with --bits 8 and
# rendered on one core with early termination 1e-3 (the faster of two
# renders). Appends rows to docs/capture_ab.csv: date, commit, CPU, cores,
# capture, configuration, minutes (empty for a fixed number of steps),
# steps, ms per step (the run's own time: compare
# rows of one run), PSNR f32, right halves without and with the fitted
# correction, PSNR int8, network evaluations and µs per ray of the int8
# render.
#
#   scripts/measure/capture_ab.sh DATA_DIR LENGTH CONFIG_JSON...
#   scripts/measure/capture_ab.sh ../shared/data/fox 2500 '{}' '{"appearance": true}'
#   scripts/measure/capture_ab.sh ../shared/data/bird 5m '{}' '{"n_coarse": 192, "n_main": 48}'
#   scripts/measure/capture_ab.sh room 5m '{}' '{"distortion": 0.001}'
#   scripts/measure/capture_ab.sh llff 3000 '{}' '{"distortion": 0.001}'
set -euo pipefail
data=$1
case $data in room | llff) ;; *) data=$(realpath "$data") ;; esac
length=$2
shift 2
case $length in
  *m) budget=(--minutes "${length%m}") ;;
  *) budget=(--iters "$length") ;;
esac
. "$(dirname "$0")/../lib/lib.sh"
builtin_capture
out_csv=docs/capture_ab.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,configuration,minutes,steps,ms_per_step,psnr,psnr_right_half,\
psnr_right_half_corrected,psnr_int8,evaluations_per_ray,us_per_ray_int8" > "$out_csv"
for cfg in "$@"; do
  out="$work/run"
  rm -rf "$out"
  echo "$cfg" > "$work/config.json"
  start=$(date +%s.%N)
  "$bin" train --data "$data" --downscale "$downscale" "${budget[@]}" --seed 0 --out "$out" --config "$work/config.json" >&2
  end=$(date +%s.%N)
  "$bin" eval "$out/model.nerf" --data "$data" --split val --save "$out/save" > "$out/eval.json"
  half=$(python3 scripts/lib/appearance_half.py "$out/save" | tail -1)
  "$bin" export "$out/model.nerf" --bits 8 --out "$out/int8.nerf" >&2
  "$bin" eval "$out/int8.nerf" --data "$data" --split val --threads 1 --repeat 2 --early-stop 1e-3 > "$out/int8.json"
  python3 - "$stamp" "$(basename "$data")" "$cfg" "$length" "$(steps "$out")" "$start" "$end" "$half" "$out" \
    >> "$out_csv" <<'PY'
import json, re, sys
stamp, cap, cfg, length, iters, start, end, half, out = sys.argv[1:]
minutes = length[:-1] if length.endswith("m") else ""
f = json.load(open(f"{out}/eval.json"))
q = json.load(open(f"{out}/int8.json"))
raw, fitted = re.findall(r"([0-9.]+) dB", half)
ms = (float(end) - float(start)) * 1000 / int(iters)
label = '"' + cfg.replace('"', "'") + '"'
print(f"{stamp},{cap},{label},{minutes},{iters},{ms:.1f},{f['psnr']:.2f},{raw},{fitted},{q['psnr']:.2f},"
      f"{q['samples_per_ray']:.2f},{q['us_per_ray']:.2f}")
PY
  tail -1 "$out_csv" >&2
done
