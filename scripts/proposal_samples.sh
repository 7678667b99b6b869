#!/usr/bin/env bash
# The network's samples per ray of a model with a proposal grid against its
# PSNR and time: renders MODEL's int8 export on DATA's held-out views at
# each sample count (`nerf eval --fine N`; the grid places them) on one
# core with early termination 1e-3, the fastest of three, and appends one
# row per count to docs/proposal_samples.csv (date, commit, CPU, cores,
# capture, samples, PSNR, network evaluations per ray, µs per ray).
#
#   scripts/proposal_samples.sh MODEL.nerf DATA_DIR CAPTURE [COUNTS...]
set -euo pipefail
model=$(realpath "$1"); data=$(realpath "$2"); name=$3; shift 3
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(8 16 24 32 48)
. "$(dirname "$0")/lib.sh"
out=docs/proposal_samples.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,capture,samples,psnr,evaluations_per_ray,us_per_ray" > "$out"
for n in "${counts[@]}"; do
  "$bin" eval "$model" --data "$data" --split val --threads 1 --repeat 3 --early-stop 1e-3 --fine "$n" \
    > "$work/eval.json"
  python3 - "$stamp" "$name" "$n" "$work/eval.json" >> "$out" <<'PY'
import json, sys
stamp, name, n, path = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{name},{n},{e['psnr']:.2f},{e['samples_per_ray']:.2f},{e['us_per_ray']:.2f}")
PY
  tail -1 "$out" >&2
done
