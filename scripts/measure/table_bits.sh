#!/usr/bin/env bash
# The feature table in 16, 8 and 4 bits: trains the default configuration
# (no --preset) on lego at 100x100 for MINUTES (seed SEED, `nerf train
# --downscale 8 --val-views 0`), exports it to int8 with each
# `--table-bits` (16: i16 values; 8 and 4: indices into a codebook per
# level), and evaluates each export on the 10 validation views with early
# termination at 1e-3 on one thread, the faster of two renders per view.
# Appends one row per export to docs/table_bits.csv: date, commit, CPU,
# cores, minutes, seed, steps, table bits, PSNR, SSIM, samples and µs per
# ray, model bytes and feature-table bytes (codebooks included).
#
#   scripts/measure/table_bits.sh [DATA_ROOT] [MINUTES] [SEED]
#
# DATA_ROOT holds lego/ (default ../shared/data); MINUTES defaults to 10,
# SEED to 0. Takes MINUTES plus about two minutes.
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-10}
seed=${3:-0}
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/table_bits.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,minutes,seed,steps,table_bits,psnr,ssim,samples,us,bytes,table_bytes" > "$out_csv"
run="$work/run"
"$bin" train --data "$root/lego" --downscale 8 --minutes "$minutes" --val-views 0 --seed "$seed" --out "$run" >&2
for b in 16 8 4; do
  "$bin" export "$run/model.nerf" --bits 8 --table-bits "$b" --out "$run/t$b.nerf" >&2
  "$bin" eval "$run/t$b.nerf" --data "$root/lego" --split val --early-stop 1e-3 --threads 1 --repeat 2 > "$run/t$b.json"
  "$bin" info "$run/t$b.nerf" --json > "$run/t$b.info.json"
  python3 - "$run" "$b" "$minutes" "$seed" "$(steps "$run")" "$stamp" >> "$out_csv" <<'PY'
import json, sys
run, b, minutes, seed, steps, stamp = sys.argv[1:]
e, i = json.load(open(f"{run}/t{b}.json")), json.load(open(f"{run}/t{b}.info.json"))
f = i["features"]
print(f"{stamp},{minutes},{seed},{steps},{b},{e['psnr']:.2f},{e['ssim']:.4f},{e['samples_per_ray']:.2f},"
      f"{e['us_per_ray']:.2f},{e['model_bytes']},{f['bytes'] + f['codebook_bytes']}")
PY
  tail -1 "$out_csv" >&2
done
