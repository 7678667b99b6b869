#!/usr/bin/env bash
# The network's samples per ray in training (`sampling.n_main`, where the
# proposal grid places them) against PSNR, step time and ray cost: bird and
# fox at 1/8 size and the built-in room (64x64, as scripts/measure/proposal.sh makes
# it) trained MINUTES at each count with no other flag (the model set to
# render at the same count), and lego at 1/8
# size once at the default (it has no proposal grid), back to back. Each
# model is scored on its held-out views in f32, exported with --bits 8 and
# rendered on one core with early termination 1e-3 (the fastest of three);
# where valgrind is installed, the int8 render's instructions per ray are
# counted by callgrind (as scripts/measure/ray_instructions.sh does, at 1/16 size
# for the photo captures to keep it short, full size for the room).
# Appends rows to docs/main_samples.csv: date, commit, CPU, cores, capture,
# n_main, minutes, steps, ms per step, PSNR f32, PSNR int8, network
# evaluations per ray, µs per ray of the int8 render, instructions per ray.
# Then the int8 models trained at the last count are rendered at each of
# RENDER's network samples (default "16 20 24") and at their own:
# scripts/measure/proposal_samples.sh (docs/proposal_samples.csv), and, where
# valgrind is installed, scripts/measure/ray_instructions.sh on lego's model and on
# their `nerf export --fine N` copies, named "CAPTURE --fine N"
# (docs/ray_instructions.csv). NERF_BIN and NERF_BIN_V3 (with NERF_COMMIT)
# name prebuilt binaries, as for the scripts it runs.
#
#   [RENDER="16 20 24"] scripts/measure/main_samples.sh [DATA_ROOT] [MINUTES] [COUNTS...]   (default counts: 16 32)
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
minutes=${2:-5}
shift $(($# < 2 ? $# : 2))
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(16 32)
. "$(dirname "$0")/../lib/lib.sh"
out_csv=docs/main_samples.csv
[ -f "$out_csv" ] || echo "date,commit,cpu,cores,capture,n_main,minutes,steps,ms_per_step,psnr,psnr_int8,\
evaluations_per_ray,us_per_ray_int8,instructions_per_ray" > "$out_csv"
if [ -n "${NERF_BIN_V3:-}" ]; then
  bin_v3=$(realpath "$NERF_BIN_V3")
elif command -v valgrind >/dev/null; then
  # valgrind cannot run AVX-512: the counting binary is built for x86-64-v3 (AVX2)
  RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin nerf --target-dir target/v3
  bin_v3=target/v3/release/nerf
fi
"$bin" scene --out "$work/scene" --size 64 >&2
run() { # name n_main data downscale count_downscale flags...
  local name=$1 n=$2 data=$3 ds=$4 cds=$5; shift 5
  local out="$work/$name-$n"
  echo "== $name n_main $n" >&2
  "$bin" train --data "$data" --downscale "$ds" --minutes "$minutes" --out "$out" "$@" >&2
  "$bin" eval "$out/model.nerf" --data "$data" --split val > "$out/eval.json"
  "$bin" export "$out/model.nerf" --bits 8 --out "$out/int8.nerf" >&2
  "$bin" eval "$out/int8.nerf" --data "$data" --split val --threads 1 --repeat 3 --early-stop 1e-3 \
    > "$out/int8.json"
  local ir=0 rays=1
  if [ -n "${bin_v3:-}" ]; then
    ir=$(render_instructions "$out/count" "$bin_v3" "$out/int8.nerf" --data "$data" --split val --downscale "$cds" \
      --threads 1 --early-stop 1e-3)
    rays=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["rays"])' "$out/count.json")
  fi
  python3 - "$stamp" "$name" "$n" "$minutes" "$(steps "$out")" "$out" "$ir" "$rays" >> "$out_csv" <<'PY'
import json, sys
stamp, name, n, minutes, steps, out, ir, rays = sys.argv[1:]
f = json.load(open(f"{out}/eval.json"))
q = json.load(open(f"{out}/int8.json"))
ms = float(minutes) * 60000 / int(steps)
count = str(int(ir) // int(rays)) if int(ir) > 0 else ""
print(f"{stamp},{name},{n},{minutes},{steps},{ms:.1f},{f['psnr']:.2f},{q['psnr']:.2f},"
      f"{q['samples_per_ray']:.2f},{q['us_per_ray']:.2f},{count}")
PY
  tail -1 "$out_csv" >&2
}
run lego - "$root/lego" 8 16
for n in "${counts[@]}"; do
  # each model renders at its own count (n_main_render 0), not at nerf train's render default
  echo "{\"sampling\": {\"n_main\": $n, \"n_main_render\": 0}}" > "$work/n_main_$n.json"
  run bird "$n" "$root/bird" 8 16 --config "$work/n_main_$n.json"
  run fox "$n" "$root/fox" 8 16 --config "$work/n_main_$n.json"
  run room "$n" "$work/scene/room" 1 1 --config "$work/n_main_$n.json"
done
last=${counts[-1]}
read -r -a render <<< "${RENDER:-16 20 24}"
for cap in bird fox room; do
  case $cap in room) data=$work/scene/room ds=1 ;; *) data=$root/$cap ds=8 ;; esac
  model=$work/$cap-$last/int8.nerf
  NERF_BIN="$bin" NERF_COMMIT="$commit" scripts/measure/proposal_samples.sh "$model" "$data" "$cap" "${render[@]}" "$last"
  [ -n "${bin_v3:-}" ] || continue
  [ "$cap" != bird ] || NERF_BIN="$bin" NERF_COMMIT="$commit" NERF_BIN_V3="$bin_v3" scripts/measure/ray_instructions.sh lego "$work/lego--/int8.nerf" "$root/lego" 8
  for f in "${render[@]}" "$last"; do
    "$bin" export "$work/$cap-$last/model.nerf" --bits 8 --fine "$f" --out "$work/$cap-fine-$f.nerf" >&2
    NERF_BIN="$bin" NERF_COMMIT="$commit" NERF_BIN_V3="$bin_v3" scripts/measure/ray_instructions.sh "$cap --fine $f" "$work/$cap-fine-$f.nerf" "$data" "$ds"
  done
done
