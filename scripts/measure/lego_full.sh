#!/usr/bin/env bash
# The default on lego at a resolution finer than 100x100 (800x800 by
# default): trains the default configuration (no --preset; its feature
# grid sized to the photos) for MINUTES at DOWNSCALE, rendering 2
# validation views every MINUTES/12 of training for the PSNR over time,
# exports it to int8, and evaluates both on the 10 validation views with
# early termination at 1e-3 on one thread. Appends one row to
# docs/lego_full.csv (date, commit, CPU, cores, downscale, minutes, steps,
# the grid's finest level and table size, the model's stratified samples
# per ray, PSNR and SSIM of f32 and int8, samples evaluated and µs per
# ray, bytes of each model, the training process's peak resident memory)
# and the validation PSNR over time to
# docs/lego_full_curve.csv.
#
#   scripts/measure/lego_full.sh [DATA_ROOT] [MINUTES] [DOWNSCALE]
#
# DATA_ROOT holds lego/ (default ../shared/data); MINUTES defaults to 60,
# DOWNSCALE to 1. A run takes MINUTES plus about five minutes.
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-60}
downscale=${3:-1}
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/lego_full.csv
curve_csv=docs/lego_full_curve.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,downscale,minutes,steps,max_res,log2_table,psnr_f32,ssim_f32,\
psnr_int8,ssim_int8,samples_f32,us_f32,us_int8,bytes_f32,bytes_int8,peak_rss_mib,coarse" > "$out_csv"
[ -f "$curve_csv" ] || echo "date,commit,cpu,cores,downscale,minutes,train_minutes,step,val_psnr" > "$curve_csv"
run="$work/run"
val_secs=$(python3 -c "print($minutes * 5)")
echo "== lego 1/$downscale, $minutes min" >&2
rss=$(python3 - "$bin" train --data "$root/lego" --downscale "$downscale" --minutes "$minutes" --val-views 2 \
  --val-secs "$val_secs" --log-every 100 --out "$run" <<'PY'
import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=sys.stderr)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024)
PY
)
"$bin" export "$run/model.nerf" --bits 8 --out "$run/int8.nerf" >&2
for m in model int8; do
  "$bin" eval "$run/$m.nerf" --data "$root/lego" --split val --early-stop 1e-3 --threads 1 --repeat 2 > "$run/$m.json"
done
"$bin" info "$run/model.nerf" --json > "$run/info.json"
python3 - "$run" "$downscale" "$minutes" "$rss" "$stamp" "$out_csv" "$curve_csv" <<'PY'
import json, sys
run, downscale, minutes, rss, stamp, out_csv, curve_csv = sys.argv[1:]
f, q, info = (json.load(open(f"{run}/{m}.json")) for m in ("model", "int8", "info"))
steps = info["trained"]["iterations"]
grid = info["features"]
with open(out_csv, "a") as o:
    o.write(f"{stamp},{downscale},{minutes},{steps},{grid['resolutions'][-1]},{grid['log2_table']},"
            f"{f['psnr']:.2f},{f['ssim']:.3f},{q['psnr']:.2f},{q['ssim']:.3f},{f['samples_per_ray']:.2f},"
            f"{f['us_per_ray']:.2f},{q['us_per_ray']:.2f},{f['model_bytes']},{q['model_bytes']},{rss},"
            f"{info['samples']['coarse']}\n")
with open(curve_csv, "a") as o:
    for line in open(f"{run}/train.jsonl"):
        r = json.loads(line)
        if r.get("val_psnr") is not None:
            o.write(f"{stamp},{downscale},{minutes},{r['train_secs'] / 60:.1f},{r['step']},{r['val_psnr']:.2f}\n")
PY
tail -1 "$out_csv" >&2
