#!/usr/bin/env bash
# lego on a microcontroller: trains lego for 10 minutes at 100x100 with the
# default preset (the README's command) and with a 2^11-entry feature table
# (`{"feature_log2_table": 11}`, small enough for 256 KiB of flash with the
# firmware), exports each to int8, prints its PSNR on the 10 validation
# views and its bytes, and runs `examples/cortex-m/run --model` with it
# (both boards; a board whose flash it does not fit is skipped).
#
#   scripts/mcu.sh [DATA_ROOT]
set -euo pipefail
root=${1:-../shared/data}
source "$(dirname "$0")/lib.sh"
echo '{"feature_log2_table": 11}' > "$work/small.json"
for run in default small; do
  config=()
  [ "$run" = small ] && config=(--config "$work/small.json")
  "$bin" train --data "$root/lego" --downscale 8 --minutes 10 "${config[@]}" --out "$work/$run" >&2
  "$bin" export "$work/$run/model.nerf" --bits 8 --out "$work/$run/int8.nerf" >&2
  echo "== $run: $(stat -c %s "$work/$run/int8.nerf") bytes, validation views:"
  "$bin" eval "$work/$run/int8.nerf" --data "$root/lego" --split val \
    | python3 -c 'import json,sys; d=json.load(sys.stdin); print("psnr %.2f dB, ssim %.3f" % (d["psnr"], d["ssim"]))'
  examples/cortex-m/run --model "$work/$run/int8.nerf" 2>&1 \
    | grep -E '^-- |^flash:|instructions|stack high-water|differ|skipped|PASS|FAIL'
done
