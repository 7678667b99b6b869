#!/usr/bin/env bash
# The default against 0cf40ca's (whose default gives unbounded scenes the
# occupancy grid's stratified samples), back to back on one machine:
# for bird and then fox, 0cf40ca's build and the working tree's each run
# `scripts/measure/captures.sh DATA_ROOT MINUTES 'CAPTURE features'` (the default
# preset, 1/8 size), appending to docs/captures.csv; RESULTS.md ("Real
# captures") pairs each baseline row with the row after it.
#
#   scripts/measure/baseline_rerun.sh [DATA_ROOT] [MINUTES]   (../shared/data, 5)
set -euo pipefail
cd "$(dirname "$0")/../.."
root=${1:-../shared/data}
minutes=${2:-5}
base=0cf40ca
work=$(mktemp -d)
trap 'git worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
git worktree add --detach "$work/base" "$base" >/dev/null 2>&1
cargo build --release --quiet
(cd "$work/base" && CARGO_TARGET_DIR="$work/target" cargo build --release --quiet --bin nerf)
cp target/release/nerf "$work/nerf-new"
head=$(git rev-parse --short HEAD)
for cap in bird fox; do
  NERF_BIN="$work/target/release/nerf" NERF_COMMIT=$base scripts/measure/captures.sh "$root" "$minutes" "$cap features"
  NERF_BIN="$work/nerf-new" NERF_COMMIT=$head scripts/measure/captures.sh "$root" "$minutes" "$cap features"
done
