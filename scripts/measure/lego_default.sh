#!/usr/bin/env bash
# The default path on lego at 100x100, as the README's results table
# reports it: trains the default configuration (no --preset) for MINUTES
# with each SEED (`nerf train --downscale 8 --val-views 0`), exports it to
# int8, and evaluates both on the 10 validation views with early
# termination at 1e-3 on one thread, the fastest of two renders per view.
# Appends one row per run to docs/lego_default.csv: date, commit, CPU,
# cores, minutes, seed, steps, PSNR and SSIM of f32 and int8, samples and
# µs per ray of each, int8 bytes, and clear_opacity (rendered opacity over
# the photos' transparent pixels: haze in empty space).
#
#   scripts/measure/lego_default.sh [DATA_ROOT] [MINUTES] [SEED...]
#
# DATA_ROOT holds lego/ (default ../shared/data); MINUTES defaults to 10,
# the seeds to 0 and 1. Each run takes MINUTES plus about a minute.
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-10}
shift $(($# < 2 ? $# : 2))
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(0 1)
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/lego_default.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,minutes,seed,steps,psnr_f32,ssim_f32,psnr_int8,ssim_int8,\
samples_f32,samples_int8,us_f32,us_int8,bytes_int8,clear_opacity" > "$out_csv"
for seed in "${seeds[@]}"; do
  run="$work/seed$seed"
  echo "== $minutes min, seed $seed" >&2
  "$bin" train --data "$root/lego" --downscale 8 --minutes "$minutes" --val-views 0 --seed "$seed" --out "$run" >&2
  "$bin" export "$run/model.nerf" --bits 8 --out "$run/int8.nerf" >&2
  for m in model int8; do
    "$bin" eval "$run/$m.nerf" --data "$root/lego" --split val --early-stop 1e-3 --threads 1 --repeat 2 > "$run/$m.json"
  done
  python3 - "$run" "$minutes" "$seed" "$(steps "$run")" "$stamp" >> "$out_csv" <<'PY'
import json, sys
run, minutes, seed, steps, stamp = sys.argv[1:]
f, q = (json.load(open(f"{run}/{m}.json")) for m in ("model", "int8"))
print(f"{stamp},{minutes},{seed},{steps},{f['psnr']:.2f},{f['ssim']:.3f},{q['psnr']:.2f},"
      f"{q['ssim']:.3f},{f['samples_per_ray']:.2f},{q['samples_per_ray']:.2f},{f['us_per_ray']:.2f},"
      f"{q['us_per_ray']:.2f},{q['model_bytes']},{f['clear_opacity']:.4f}")
PY
  tail -1 "$out_csv" >&2
done
