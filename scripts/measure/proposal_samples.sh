#!/usr/bin/env bash
# The samples per ray of a model with a proposal grid against its PSNR and
# time: renders MODEL (an int8 export) on DATA's held-out views at each
# count (N: the network's samples, `nerf eval --fine N`, the grid placing
# them among the model's stratified samples; S/N: S stratified samples
# composite the grid, `--coarse S`) on one core with early termination
# 1e-3, the fastest of three, and appends one row per count to
# docs/proposal_samples.csv (date, commit, CPU, cores, capture, stratified
# samples, network samples, PSNR, network evaluations per ray, µs per ray).
#
#   scripts/measure/proposal_samples.sh MODEL.nerf DATA_DIR CAPTURE [COUNTS...]
set -euo pipefail
model=$(realpath "$1"); data=$(realpath "$2"); name=$3; shift 3
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(8 16 24 32 48 96/16 96/24)
. "$(dirname "$0")/../lib/lib.sh"
out=docs/proposal_samples.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,capture,stratified,samples,psnr,evaluations_per_ray,us_per_ray" > "$out"
default_s=$("$bin" info "$model" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["samples"]["coarse"])')
for c in "${counts[@]}"; do
  if [[ "$c" == */* ]]; then s=${c%/*}; n=${c#*/}; else s=$default_s; n=$c; fi
  "$bin" eval "$model" --data "$data" --split val --threads 1 --repeat 3 --early-stop 1e-3 --coarse "$s" \
    --fine "$n" > "$work/eval.json"
  python3 - "$stamp" "$name" "$s" "$n" "$work/eval.json" >> "$out" <<'PY'
import json, sys
stamp, name, s, n, path = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{name},{s},{n},{e['psnr']:.2f},{e['samples_per_ray']:.2f},{e['us_per_ray']:.2f}")
PY
  tail -1 "$out" >&2
done
