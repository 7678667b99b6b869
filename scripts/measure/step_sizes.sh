#!/usr/bin/env bash
# Training throughput against photo size, in one run: lego trained STEPS
# steps at each DOWNSCALE (8: 100x100, 1: 800x800), once with the default
# flags (the feature grid and the samples per ray sized to the photos)
# and once with the configuration the 100x100 photos get (`--config`
# naming the preset's feature grid and samples, so only the photos
# differ). Appends one row per run to docs/step_sizes.csv: date, commit,
# CPU, cores, downscale, configuration, steps, training rays per second
# and samples per ray over the last LOG steps, ms per step and its
# wall-clock stages (occupancy grid refresh, batch draw, chunks, table
# scatter, Adam and the average), and the process's peak memory in MiB.
#
#   scripts/measure/step_sizes.sh [DATA_ROOT] [STEPS] [DOWNSCALE...]
#   scripts/measure/step_sizes.sh ../shared/data 1500 8 1
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
steps=${2:-1500}
shift $(($# < 2 ? $# : 2))
scales=("$@")
[ ${#scales[@]} -gt 0 ] || scales=(8 1)
. "$(dirname "$0")/../lib/lib.sh"
out=docs/step_sizes.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,downscale,config,steps,rays_per_sec,samples_per_ray,ms_per_step,grid,draw,\
chunks,scatter,adam,peak_mib" > "$out"
log=$((steps / 3))
echo '{"features": {"max_res": 256, "log2_table": 15}, "sampling": {"n_coarse": 192}}' > "$work/small.json"
for ds in "${scales[@]}"; do
  for config in default small; do
    flags=()
    [ "$config" = small ] && flags=(--config "$work/small.json")
    run="$work/run_${ds}_$config"
    # the run's peak resident memory (KiB) as the kernel counts it for a child process
    python3 -c 'import resource, subprocess, sys; subprocess.run(sys.argv[2:], check=True)
open(sys.argv[1], "w").write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))' "$work/peak" "$bin" train --data "$root/lego" --downscale "$ds" --iters "$steps" \
      --val-views 0 --log-every "$log" --seed 0 --out "$run" "${flags[@]}" >&2
    python3 - "$stamp" "$ds" "$config" "$steps" "$run/train.jsonl" "$work/peak" >> "$out" <<'PY'
import json, sys
stamp, ds, config, steps, log, peak = sys.argv[1:]
last = [json.loads(l) for l in open(log)][-1]
ms = last["step_ms"]
spr = last["samples_per_sec"] / last["rays_per_sec"]
stages = ",".join(f"{ms[k]:.2f}" for k in ("grid", "draw", "chunks", "scatter", "adam"))
total = sum(ms[k] for k in ("grid", "draw", "chunks", "scatter", "adam"))
kib = int(open(peak).read().split()[-1])
print(f"{stamp},{ds},{config},{steps},{last['rays_per_sec']:.0f},{spr:.1f},{total:.2f},{stages},{kib / 1024:.0f}")
PY
    tail -1 "$out" >&2
  done
done
