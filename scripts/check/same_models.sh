#!/usr/bin/env bash
# Whether two builds train the same models byte for byte: the built-in
# scene (24x24, 8 photos) trained 60 steps with seed 3 under the default,
# grid and fast presets and its room 40 steps at half size, each exported to
# int16 and int8, by the working tree's build and by BASE's (a commit,
# default HEAD~1), and the files compared. For changes meant not to change
# what training computes (reorganising code). BASE_BIN names BASE's binary
# when it is already built (else it is built in a worktree).
#
#   scripts/check/same_models.sh [BASE]
#   BASE_BIN=old/nerf scripts/check/same_models.sh b85dbb6
set -euo pipefail
given=${BASE_BIN:+$(realpath "$BASE_BIN")}
[ -z "$given" ] || [ -x "$given" ] || { echo "BASE_BIN=$BASE_BIN: not an executable" >&2; exit 2; }
cd "$(dirname "$0")/../.."
base=${1:-HEAD~1}
work=$(mktemp -d)
trap 'git worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
cargo build --release --quiet
if [ -n "$given" ]; then
  base_bin=$given
else
  git worktree add --detach "$work/base" "$base" >/dev/null 2>&1
  (cd "$work/base" && CARGO_TARGET_DIR="$work/target" cargo build --release --quiet)
  base_bin=$work/target/release/nerf
fi
target/release/nerf scene --out "$work/scene" --size 24 --train 8 >/dev/null
run() {  # BIN OUT
  for p in default grid fast; do
    flags=(); [ $p != default ] && flags=(--preset $p)
    "$1" train --data "$work/scene/blender" --iters 60 --seed 3 "${flags[@]}" --out "$2/$p" >/dev/null 2>&1
  done
  "$1" train --data "$work/scene/room" --iters 40 --seed 3 --downscale 2 --out "$2/room" >/dev/null 2>&1
  for r in default grid fast room; do
    "$1" export "$2/$r/model.nerf" --bits 8 --out "$2/$r/int8.nerf" >/dev/null 2>&1
    "$1" export "$2/$r/model.nerf" --bits 16 --out "$2/$r/int16.nerf" >/dev/null 2>&1
  done
}
run target/release/nerf "$work/new"
run "$base_bin" "$work/old"
differ=0
for r in default grid fast room; do
  for f in model int8 int16; do
    if cmp -s "$work/new/$r/$f.nerf" "$work/old/$r/$f.nerf"; then s=same; else s=DIFFERENT; differ=1; fi
    echo "$r/$f.nerf: $s ($(stat -c %s "$work/new/$r/$f.nerf") bytes)"
  done
done
exit $differ
