#!/usr/bin/env bash
# Models on a microcontroller (QEMU, `examples/cortex-m/run`): the shipped
# int8 and int16 models of the built-in scene (`builtin`), then lego
# trained for 10 minutes at 100x100 with the default preset (`default`, the
# README's command), with a 2^11-entry feature table (`small`:
# `{"feature_log2_table": 11}`, small enough for 256 KiB of flash with the
# firmware) and with a 2^13-entry table stored as 4-bit codes (`narrow`:
# `{"feature_log2_table": 13}`, `nerf export --table-bits 4`, the same
# flash as `small`), each exported to int8 and run alone with `run
# --model` on both boards (a board whose flash it does not fit is skipped). Appends one row per model and board to
# docs/mcu.csv: date, commit, CPU, cores, model, its PSNR on lego's 10
# validation views (empty for the built-in scene), board, model bytes,
# firmware flash bytes, stack high-water mark in bytes, instructions per
# ray (mean, min, max over the 8x8 tile) and whether every pixel equals
# the host's render.
#
#   scripts/measure/mcu.sh [DATA_ROOT] [RUN...]
#
# RUN: builtin, default, small, narrow (default: all four).
set -euo pipefail
root=${1:-../shared/data}
shift $(($# < 1 ? $# : 1))
runs=("$@")
[ ${#runs[@]} -gt 0 ] || runs=(builtin default small narrow)
source "$(dirname "$0")/../lib/lib.sh"
out=docs/mcu.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,model,psnr_val,board,model_bytes,flash_bytes,stack_bytes,\
instr_per_ray,instr_min,instr_max,bit_exact" > "$out"

# firmware LABEL PSNR [run flags...]: runs the firmware, appends its rows
firmware() {
  local label=$1 psnr=$2
  shift 2
  examples/cortex-m/run "$@" 2>&1 | tee "$work/run.log" >&2
  python3 - "$stamp" "$label" "$psnr" "$work/run.log" >> "$out" <<'PY'
import csv, re, sys
stamp, label, psnr, log = sys.argv[1:]
out = csv.writer(sys.stdout, lineterminator="\n")
board = flash = None
models = {}
for line in open(log):
    if m := re.match(r"nerf-cortex-m on (\S+):", line):
        board, models = m.group(1), {}
    elif m := re.match(r"flash: (\d+) bytes", line):
        flash = m.group(1)
    elif m := re.match(r"(\w+): (\d+) bytes in flash", line):
        models[m.group(1)] = {"bytes": m.group(2)}
    elif m := re.match(r"(\w+): tile \S+ = \d+ instructions; per ray (\d+) mean, (\d+) min, (\d+) max", line):
        models[m.group(1)].update(mean=m.group(2), lo=m.group(3), hi=m.group(4))
    elif m := re.match(r"(\w+): checksum .*: (BIT-EXACT|MISMATCH)", line):
        models[m.group(1)]["exact"] = "yes" if m.group(2) == "BIT-EXACT" else "no"
    elif m := re.match(r"ram: stack high-water (\d+) bytes", line):
        for name, r in models.items():
            model = label if name == "model" else f"{label} {name}"
            out.writerow(stamp.split(",") + [model, psnr, board, r["bytes"], flash, m.group(1), r["mean"], r["lo"],
                                             r["hi"], r["exact"]])
PY
}

echo '{"feature_log2_table": 11}' > "$work/small.json"
echo '{"feature_log2_table": 13}' > "$work/narrow.json"
for run in "${runs[@]}"; do
  config=() table=(--table-bits 16)
  case $run in
    builtin) firmware "built-in scene" ""; continue ;;
    default) label="lego int8, default" ;;
    small) label="lego int8, 2¹¹ table"; config=(--config "$work/small.json") ;;
    narrow) label="lego int8, 2¹³ table in 4-bit codes"; config=(--config "$work/narrow.json") table=(--table-bits 4) ;;
    *) echo "unknown run '$run' (builtin, default, small, narrow)" >&2; exit 2 ;;
  esac
  "$bin" train --data "$root/lego" --downscale 8 --minutes 10 "${config[@]}" --out "$work/$run" >&2
  "$bin" export "$work/$run/model.nerf" --bits 8 "${table[@]}" --out "$work/$run/int8.nerf" >&2
  psnr=$("$bin" eval "$work/$run/int8.nerf" --data "$root/lego" --split val \
    | python3 -c 'import json,sys; print("%.2f" % json.load(sys.stdin)["psnr"])')
  firmware "$label" "$psnr" --model "$work/$run/int8.nerf"
done
tail -n +2 "$out" | tail -8 >&2
