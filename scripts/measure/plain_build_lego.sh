#!/usr/bin/env bash
# nerf-infer in a crate built without target flags, on lego: trains the
# default for MINUTES at 100x100 (`nerf train --downscale 8`, seed 0),
# exports it to int8, and renders the first view of each model's orbit at
# 100x100 with examples/quickstart built as users build it (no target
# flags) and with -C target-cpu=native (scripts/check/plain_build.sh: one thread,
# early termination 1e-3, the faster of two). Appends to
# docs/plain_build.csv: date, commit, CPU, cores, minutes, steps, model,
# build, µs per ray, kernels, whether the picture equals the native build's.
# Then renders both with the quick start's scratch at each block size
# (scripts/measure/block_sizes.sh, plain builds) and appends to
# docs/block_sizes.csv: date, commit, CPU, cores, minutes, steps, model,
# block, µs per ray, kernels, whether the picture equals blocks of 1's.
#
#   scripts/measure/plain_build_lego.sh [DATA_ROOT] [MINUTES]   (../shared/data, 10)
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-10}
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/plain_build.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,minutes,steps,model,build,us_per_ray,kernels,same_picture" > "$out_csv"
run="$work/lego"
"$bin" train --data "$root/lego" --downscale 8 --minutes "$minutes" --val-views 0 --seed 0 --out "$run" >&2
"$bin" export "$run/model.nerf" --bits 8 --out "$run/int8.nerf" >&2
n=$(steps "$run")
scripts/check/plain_build.sh --size 100 "$run/model.nerf" "$run/int8.nerf" | tail -n +2 | while IFS=, read -r m build us kernels same; do
  echo "$stamp,$minutes,$n,$(basename "$m" .nerf),$build,$us,$kernels,$same" | tee -a "$out_csv" >&2
done
blocks_csv=docs/block_sizes.csv
[ -f "$blocks_csv" ] || echo "date,commit,cpu,cores,minutes,steps,model,block,us_per_ray,kernels,same_picture" > "$blocks_csv"
scripts/measure/block_sizes.sh --size 100 "$run/model.nerf" "$run/int8.nerf" | tail -n +2 | while IFS=, read -r m block us kernels same; do
  echo "$stamp,$minutes,$n,$(basename "$m" .nerf),$block,$us,$kernels,$same" | tee -a "$blocks_csv" >&2
done
