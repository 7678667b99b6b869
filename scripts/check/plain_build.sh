#!/usr/bin/env bash
# A crate that depends on nerf-infer, built as users build it (no target
# flags) against the same crate built with -C target-cpu=native (as the
# workspace builds): examples/quickstart renders each MODEL's first orbit
# view at SIZE (default 100) twice with each build, one thread; prints the
# faster time per ray of each, and whether the two builds' pictures are
# byte for byte the same (exit status 1 if not).
#
#   scripts/check/plain_build.sh [--size N] MODEL...
#
# e.g. a lego run's f32 and int8 models (scripts/measure/lego_default.sh keeps
# neither; `nerf train ... --out RUN && nerf export RUN/model.nerf --bits 8
# --out RUN/int8.nerf`): scripts/check/plain_build.sh RUN/model.nerf RUN/int8.nerf
set -euo pipefail
cd "$(dirname "$0")/../.."
. scripts/lib/quickstart_time.sh
size=100
if [ "${1:-}" = "--size" ]; then size=$2; shift 2; fi
[ $# -gt 0 ] || { echo "usage: $0 [--size N] MODEL..." >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for build in plain native; do
    flags=""; [ $build = native ] && flags="-C target-cpu=native"
    RUSTFLAGS="$flags" CARGO_TARGET_DIR="$work/$build" \
        cargo build --quiet --release --manifest-path examples/quickstart/Cargo.toml
    mkdir -p "$work/run-$build"
done
differ=0
echo "model,build,us_per_ray,kernels,same_picture"
for m in "$@"; do
    m=$(realpath "$m")
    for build in plain native; do
        fastest_ray "$work/$build/release/nerf-quickstart" "$m" "$size" "$work/run-$build"
        same=""
        if [ $build = native ]; then
            if cmp -s "$work/run-plain/view.ppm" "$work/run-native/view.ppm"; then same=yes; else same=NO; differ=1; fi
        fi
        echo "$m,$build,$best,$kernels,$same"
    done
done
exit $differ
