#!/usr/bin/env bash
# What the build profile of a crate that depends on nerf-infer does to its
# renders: examples/quickstart (a crate outside the workspace, no target
# flags) built in release and in debug at opt-level 0, 0 with nerf-infer's
# own package at 3, and 1, renders the shipped int8 model (48x48, one
# thread) with each; prints microseconds per ray and the ratio to release.
# The renderer is generic, so most of it is compiled in the program's own
# crate with the program's profile.
#
#   scripts/measure/quickstart_profiles.sh [MODEL]   (default models/scene_int8.nerf)
set -euo pipefail
cd "$(dirname "$0")/../.."
model=$(realpath "${1:-models/scene_int8.nerf}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
manifest=examples/quickstart/Cargo.toml
declare -A flags=(
    [release]="--release"
    [debug-opt0]="--config profile.dev.package.nerf-infer.opt-level=0"
    [debug-opt0-nerf-infer-opt3]=""
    [debug-opt1]="--config profile.dev.opt-level=1"
)
us() { (cd "$work" && "$1" "$model" 48) | sed -n 's/.* \([0-9.]*\) µs per ray.*/\1/p'; }
declare -A t
for name in release debug-opt0 debug-opt0-nerf-infer-opt3 debug-opt1; do
    # shellcheck disable=SC2086
    RUSTFLAGS="" CARGO_TARGET_DIR="$work/$name" cargo build --quiet --manifest-path "$manifest" ${flags[$name]}
    dir=debug; [ "$name" = release ] && dir=release
    t[$name]=$(us "$work/$name/$dir/nerf-quickstart")
done
echo "profile,us_per_ray,x_release"
for name in release debug-opt0 debug-opt0-nerf-infer-opt3 debug-opt1; do
    python3 -c "import sys; print(f'{sys.argv[1]},{float(sys.argv[2]):.2f},{float(sys.argv[2]) / float(sys.argv[3]):.1f}')" \
        "$name" "${t[$name]}" "${t[release]}"
done
