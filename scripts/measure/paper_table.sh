#!/usr/bin/env bash
# The NeRF paper's protocol through `nerf bench`: each SCENE folder (lego:
# full size, white background; flower: 1/4 size, every 8th photo held out)
# benched for MINUTES of training with the default flags, one bench each.
# Appends each row of the bench's table.csv to docs/paper_table.csv with
# the date, commit, CPU and cores, and copies the bench's plot of PSNR
# against minutes to docs/paper_SCENE.png.
#
#   scripts/measure/paper_table.sh SCENE_DIR MINUTES [SCENE_DIR MINUTES ...]
#   scripts/measure/paper_table.sh ../shared/data/flower 20
#   scripts/measure/paper_table.sh ../shared/data/lego 60
set -euo pipefail
[ $# -ge 2 ] && [ $(($# % 2)) -eq 0 ] || { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
args=("$@")
for ((i = 0; i < ${#args[@]}; i += 2)); do args[i]=$(realpath "${args[i]}"); done
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/paper_table.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,scene,kind,width,height,split,views,minutes,steps,psnr_f32,ssim_f32,\
psnr_int8,ssim_int8,us_per_ray_f32,us_per_ray_int8,bytes_int8,peak_mib,nerf_psnr,nerf_ssim" > "$out_csv"
for ((i = 0; i < ${#args[@]}; i += 2)); do
  scene=${args[i]} minutes=${args[i + 1]}
  name=$(basename "$scene")
  "$bin" bench "$scene" --minutes "$minutes" --out "$work/$name" >&2
  cp "$work/$name/psnr_minutes.png" "docs/paper_$name.png"
  python3 - "$stamp" "$work/$name/table.csv" >> "$out_csv" <<'PY'
import csv, sys
stamp, path = sys.argv[1:]
for r in csv.DictReader(open(path)):
    cols = ["scene", "kind", "width", "height", "split", "views", "minutes", "steps", "psnr_f32", "ssim_f32",
            "psnr_int8", "ssim_int8", "us_per_ray_f32", "us_per_ray_int8", "bytes_int8", "peak_mib", "nerf_psnr",
            "nerf_ssim"]
    print(stamp + "," + ",".join(r[c] for c in cols))
PY
  tail -1 "$out_csv" >&2
done
