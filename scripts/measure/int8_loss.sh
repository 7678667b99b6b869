#!/usr/bin/env bash
# The int8 loss of every preset on lego: trains each PRESET for MINUTES at
# 1/8 size (100x100), exports it to int8 (`nerf export --bits 8`) and
# evaluates both on the 10 validation views with the same samples and early
# termination (1e-3); µs per ray per core. Appends one row per preset to
# docs/int8_loss.csv: date, commit, CPU, cores, preset, minutes, steps, PSNR f32 and
# int8, the loss, bytes and µs per ray of each.
#
#   scripts/measure/int8_loss.sh [DATA_ROOT] [MINUTES] [PRESET...]
#
# DATA_ROOT holds lego/; presets default to fast, grid, features and paper.
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-3}
shift $(($# < 2 ? $# : 2))
presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(fast grid features paper)
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/int8_loss.csv
[ -f "$out_csv" ] ||
  echo "date,commit,cpu,cores,preset,minutes,steps,psnr_f32,psnr_int8,loss_db,bytes_f32,bytes_int8,us_f32,us_int8" > "$out_csv"
for p in "${presets[@]}"; do
  run="$work/$p"
  echo "== $p" >&2
  "$bin" train --data "$root/lego" --downscale 8 --minutes "$minutes" --preset "$p" --out "$run" >&2
  "$bin" export "$run/model.nerf" --bits 8 --out "$run/int8.nerf" >&2
  for m in model int8; do
    "$bin" eval "$run/$m.nerf" --data "$root/lego" --split val --early-stop 1e-3 > "$run/$m.json"
  done
  python3 - "$run" "$p" "$minutes" "$(steps "$run")" "$stamp" >> "$out_csv" <<'PY'
import json, sys
run, preset, minutes, steps, stamp = sys.argv[1:]
f, q = (json.load(open(f"{run}/{m}.json")) for m in ("model", "int8"))
print(f"{stamp},{preset},{minutes},{steps},{f['psnr']:.3f},{q['psnr']:.3f},"
      f"{f['psnr'] - q['psnr']:.3f},{f['model_bytes']},{q['model_bytes']},{f['us_per_ray']:.2f},{q['us_per_ray']:.2f}")
PY
  tail -1 "$out_csv" >&2
done
