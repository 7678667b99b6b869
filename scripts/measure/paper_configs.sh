#!/usr/bin/env bash
# Configurations compared at the NeRF paper's protocol, back to back:
# `nerf bench SCENE_DIR` (flower: 1/4 size, every 8th photo held out;
# lego: full size, white background) for LENGTH (ITERS steps, or with an
# m suffix that many minutes) once per CONFIG_JSON (the default with that
# configuration's fields on top, as `--config` takes them; `{}` is the
# default). Appends one row per configuration to docs/paper_configs.csv:
# date, commit, CPU, cores, scene, configuration, minutes of training,
# steps, ms per step over the run (compare rows of one run), PSNR and
# SSIM in f32 on the held-out views, PSNR int8, µs per int8 ray on one
# core, peak memory in MiB and the training seed (SEED, default 0).
#
#   [SEED=N] scripts/measure/paper_configs.sh SCENE_DIR LENGTH CONFIG_JSON...
#   scripts/measure/paper_configs.sh ../shared/data/flower 7400 '{}' '{"features": {"levels": 16}}'
#   SEED=1 scripts/measure/paper_configs.sh ../shared/data/flower 14942 '{"sampling": {"batch_rays": 2048}}'
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
scene=$(realpath "$1")
length=$2
shift 2
case $length in
  *m) budget=(--minutes "${length%m}") ;;
  *) budget=(--iters "$length") ;;
esac
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/paper_configs.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,scene,configuration,minutes,steps,ms_per_step,psnr_f32,ssim_f32,\
psnr_int8,us_per_ray_int8,peak_mib,seed" > "$out_csv"
i=0
for cfg in "$@"; do
  i=$((i + 1))
  echo "$cfg" > "$work/config_$i.json"
  "$bin" bench "$scene" "${budget[@]}" --config "$work/config_$i.json" --seed "${SEED:-0}" --out "$work/bench_$i" >&2
  python3 - "$stamp" "$cfg" "$work/bench_$i" "${SEED:-0}" >> "$out_csv" <<'PY'
import csv, glob, json, sys
stamp, cfg, out, seed = sys.argv[1:]
row = next(csv.DictReader(open(f"{out}/table.csv")))
log = [json.loads(l) for l in open(glob.glob(f"{out}/scenes/*/run/train.jsonl")[0])]
last = log[-1]
ms = 1000 * last["train_secs"] / last["step"] if last["step"] else float("nan")
q = '"' + cfg.replace('"', "'") + '"'
print(f"{stamp},{row['scene']},{q},{row['minutes']},{row['steps']},{ms:.1f},{row['psnr_f32']},{row['ssim_f32']},"
      f"{row['psnr_int8']},{row['us_per_ray_int8']},{row['peak_mib']},{seed}")
PY
  tail -1 "$out_csv" >&2
done
