#!/usr/bin/env bash
# What each render knob costs and buys on the default's lego model: trains
# the default (no --preset) for MINUTES at 100x100 with seed 0, then runs
# `nerf tradeoff` on the 10 validation views (5 interleaved timed
# repetitions per point, one thread): weight bits, samples and early
# termination, each varied alone. Writes docs/tradeoff_lego8.png and
# docs/tradeoff_lego8.csv (`nerf tradeoff`'s columns after the date,
# commit, CPU, cores and training minutes of the run; replaced, not
# appended, since the plot shows one model).
#
#   scripts/measure/tradeoff.sh [DATA_ROOT] [MINUTES]
set -euo pipefail
root=${1:-../shared/data}
minutes=${2:-10}
. "$(dirname "$0")/../lib/lib.sh"
"$bin" train --data "$root/lego" --downscale 8 --minutes "$minutes" --val-views 0 --seed 0 --out "$work/lego" >&2
"$bin" tradeoff "$work/lego/model.nerf" --data "$root/lego" --split val --views 10 --repeats 5 --out "$work/t" >&2
awk -v s="$stamp,$minutes" 'NR == 1 { print "date,commit,cpu,cores,minutes," $0; next } { print s "," $0 }' \
  "$work/t/tradeoff.csv" > "$work/t/stamped.csv"
mv "$work/t/stamped.csv" docs/tradeoff_lego8.csv
mv "$work/t/tradeoff.png" docs/tradeoff_lego8.png
cat docs/tradeoff_lego8.csv >&2
