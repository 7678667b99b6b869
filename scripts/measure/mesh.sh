#!/usr/bin/env bash
# The mesh of lego: trains the default preset for 10 minutes at 100x100
# (or takes MODEL), extracts the surface at two lattice resolutions, and
# appends to docs/mesh.csv (labelled with date, commit, CPU and cores) its size
# (with the default --threshold and --min-piece, which the rows record),
# area, volume, closure, the silhouette IoU against the alpha masks of
# the 10 validation views, and the seconds `nerf mesh` took.
#
#   scripts/measure/mesh.sh [DATA_ROOT] [MODEL]
set -euo pipefail
root=${1:-../shared/data}
source "$(dirname "$0")/../lib/lib.sh"
model=${2:-}
if [ -z "$model" ]; then
  "$bin" train --data "$root/lego" --downscale 8 --minutes 10 --out "$work/lego" >&2
  model="$work/lego/model.nerf"
fi
out=docs/mesh.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,model_psnr_val,resolution,threshold,min_piece,vertices,triangles,area,volume,closed,silhouette_iou_val,seconds" > "$out"
psnr=$("$bin" eval "$model" --data "$root/lego" --split val | python3 -c 'import json,sys; print("%.2f" % json.load(sys.stdin)["psnr"])')
for res in 128 256; do
  start=$(date +%s.%N)
  "$bin" mesh "$model" --out "$work/lego$res.ply" --resolution "$res" --masks "$root/lego" --split val > "$work/mesh.json"
  end=$(date +%s.%N)
  python3 - "$work/mesh.json" "$stamp" "$psnr" "$start" "$end" >> "$out" <<'PY'
import json, sys
path, stamp, psnr, start, end = sys.argv[1:]
m = json.load(open(path))
print(f"{stamp},{psnr},{m['resolution']},{m['threshold']},{m['min_piece']},{m['vertices']},{m['triangles']},"
      f"{m['area']:.4f},{m['volume']:.4f},{m['closed']},{m['silhouette_iou']:.4f},{float(end) - float(start):.1f}")
PY
  tail -1 "$out" >&2
done
