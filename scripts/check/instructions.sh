#!/usr/bin/env bash
# Instructions per ray of the renderer, counted by callgrind: the inclusive
# count of `render_view` divided by the rays rendered (lego's 10 validation
# views at 1/40 size, 4000 rays, early termination at 1e-3), for the f32,
# int16 and int8 exports of two lego models (the default preset for
# 2 minutes, the fast preset for 1 minute), with the binaries of two
# commits built for x86-64-v3 (AVX2; valgrind cannot run AVX-512). Counts
# are exact and do not depend on the machine's load; PSNR shows that the
# pixels agree.
#
#   scripts/check/instructions.sh [DATA_ROOT] [BASE_COMMIT] [NEW_COMMIT]
set -euo pipefail
root=${1:-../shared/data}
base=${2:-HEAD~1}
new=${3:-HEAD}
cd "$(dirname "$0")/../.."
command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 1; }
work=$(mktemp -d)
trap 'git worktree remove --force "$work/src" 2>/dev/null || true; rm -rf "$work"' EXIT
cargo build --release --quiet
tdir="$PWD/target/v3"
for rev in "$base" "$new"; do
  git worktree add --force --detach "$work/src" "$rev" >/dev/null 2>&1
  (cd "$work/src" && RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin nerf --target-dir "$tdir")
  cp "$tdir/release/nerf" "$work/nerf-$(git rev-parse --short "$rev")"
  git worktree remove --force "$work/src"
done
train() { target/release/nerf train --data "$root/lego" --downscale 8 --val-views 0 --out "$work/$1" "${@:2}" >&2; }
train default --minutes 2
train fast --minutes 1 --preset fast
for run in default fast; do
  for bits in 16 8; do
    target/release/nerf export "$work/$run/model.nerf" --bits $bits --out "$work/$run/int$bits.nerf" >&2
  done
done
echo "model,commit,instructions_per_ray,psnr"
for m in default/model default/int16 default/int8 fast/model fast/int16 fast/int8; do
  for rev in "$base" "$new"; do
    c=$(git rev-parse --short "$rev")
    out="$work/cg.$c"
    valgrind --tool=callgrind --callgrind-out-file="$out" --toggle-collect='*render_view*' "$work/nerf-$c" eval \
      "$work/$m.nerf" --data "$root/lego" --split val --downscale 40 --threads 1 --early-stop 1e-3 \
      > "$out.json" 2>/dev/null
    # awk reads to the end (grep -m1 would stop the pipe early and fail it under pipefail)
    ir=$(callgrind_annotate "$out" 2>/dev/null | awk '/PROGRAM TOTALS/ && !n {gsub(",", "", $1); print $1; n = 1}')
    psnr=$(python3 -c 'import json,sys; print("%.6f" % json.load(open(sys.argv[1]))["psnr"])' "$out.json")
    echo "$m,$c,$((ir / 4000)),$psnr"
  done
done
