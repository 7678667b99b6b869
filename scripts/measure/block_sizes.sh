#!/usr/bin/env bash
# Which block of samples renders fastest from a crate outside the
# workspace: examples/quickstart copied with its scratch typed
# `AnyScratch<B>` for each B in BLOCKS, built as users build it (no target
# flags, nerf-infer with `std`), renders each MODEL's first orbit view at
# SIZE (default 100) on one thread, early termination 1e-3; prints the
# fastest of three times per ray for each model and block, and whether the
# picture is byte for byte the one of the first block (exit status 1 if
# not). The default block of `AnyScratch` with `std` is chosen from it
# (docs/RESULTS.md "Samples per block").
#
#   scripts/measure/block_sizes.sh [--size N] [--blocks "1 2 4 8 16 32"] MODEL...
set -euo pipefail
cd "$(dirname "$0")/../.."
. scripts/lib/quickstart_time.sh
size=100
blocks="1 2 4 8 16 32"
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --blocks) blocks=$2; shift 2 ;;
    *) break ;;
  esac
done
[ $# -gt 0 ] || { echo "usage: $0 [--size N] [--blocks LIST] MODEL..." >&2; exit 2; }
infer=$(realpath nerf-infer)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for b in $blocks; do
  crate="$work/quickstart-$b"
  cp -r examples/quickstart "$crate"
  rm -rf "$crate/target"
  sed -i "s|path = \"../../nerf-infer\"|path = \"$infer\"|" "$crate/Cargo.toml"
  # the scratch of the quick start, at this block size
  sed -i "s|Box<AnyScratch\(<[0-9]*>\)\?>|Box<AnyScratch<$b>>|" "$crate/src/main.rs"
  grep -q "Box<AnyScratch<$b>>" "$crate/src/main.rs" || { echo "examples/quickstart: no scratch to set" >&2; exit 2; }
  RUSTFLAGS="" CARGO_TARGET_DIR="$work/target" cargo build --quiet --release --manifest-path "$crate/Cargo.toml"
  cp "$work/target/release/nerf-quickstart" "$work/quickstart-$b.bin"
  mkdir -p "$work/run-$b"
done
differ=0
first=${blocks%% *}
echo "model,block,us_per_ray,kernels,same_picture"
for m in "$@"; do
  m=$(realpath "$m")
  for b in $blocks; do
    fastest_ray "$work/quickstart-$b.bin" "$m" "$size" "$work/run-$b" 3
    same=yes
    cmp -s "$work/run-$first/view.ppm" "$work/run-$b/view.ppm" || { same=NO; differ=1; }
    echo "$(basename "$m"),$b,$best,$kernels,$same"
  done
done
exit $differ
