#!/usr/bin/env bash
# Instructions per ray of a model's render, counted by callgrind: the
# inclusive count of `render_view` over its held-out views (--split val)
# at 1/DOWNSCALE of the photos (default 8), one thread, early termination 1e-3,
# divided by the rays rendered. The binary is built for x86-64-v3 (AVX2;
# valgrind cannot run AVX-512), or NERF_BIN_V3 names one. Counts are exact
# and do not depend on the machine's load, so the ratio of two captures'
# counts is a stable figure where µs per ray is noisy. Appends a row to
# docs/ray_instructions.csv: date, commit, CPU, cores, capture, scheme,
# downscale, rays, network evaluations per ray, instructions per ray and
# PSNR of that render.
#
#   scripts/measure/ray_instructions.sh CAPTURE MODEL DATA [DOWNSCALE]
set -euo pipefail
name=$1
model=$(realpath "$2")
data=$(realpath "$3")
ds=${4:-8}
given_v3=${NERF_BIN_V3:+$(realpath "$NERF_BIN_V3")}
. "$(dirname "$0")/../lib/lib.sh"
valgrind_bin
out_csv=docs/ray_instructions.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,scheme,downscale,rays,evaluations_per_ray,\
instructions_per_ray,psnr" > "$out_csv"
ir=$(render_instructions "$work/eval" "$bin" "$model" --data "$data" --split val --downscale "$ds" --threads 1 \
  --early-stop 1e-3)
python3 - "$stamp" "$name" "$ds" "$ir" "$work/eval.json" >> "$out_csv" <<'PY'
import json, sys
stamp, name, ds, ir, path = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{name},{e['scheme']},{ds},{e['rays']},{e['samples_per_ray']:.2f},{int(ir) // e['rays']},{e['psnr']:.2f}")
PY
tail -1 "$out_csv" >&2
