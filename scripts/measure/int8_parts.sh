#!/usr/bin/env bash
# What the 16-bit parts of int8 models (format version 6: the view layer's
# direction rows, the colour head) change, on one trained f32 lego model:
# the int8 export of two commits (before and after the parts), each
# evaluated by its own build on lego's 10 validation views at the model's
# size (PSNR, SSIM, µs per ray on one core with early termination at 1e-3,
# the two timed back to back in alternation), and instructions per ray
# counted by callgrind at 1/40 size on x86-64-v3 builds (valgrind cannot run
# AVX-512). With --layers, also the PSNR of the newer build's int16 export
# with each layer alone rounded to the int8 export's precision.
#
#   scripts/measure/int8_parts.sh MODEL [DATA_ROOT] [BASE_COMMIT] [NEW_COMMIT] [--layers]
#
# MODEL: an f32 model trained on lego, e.g. by
#   nerf train --data ../shared/data/lego --downscale 8 --minutes 10 --out runs/feat8
set -euo pipefail
model=$(realpath "$1")
root=$(realpath "${2:-../shared/data}")
base=${3:-6eb4826}
new=${4:-HEAD}
layers=${5:-}
cd "$(dirname "$0")/../.."
command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 1; }
work=$(mktemp -d)
trap 'git worktree remove --force "$work/src" 2>/dev/null || true; rm -rf "$work"' EXIT
revs=()
tdir="$PWD/target"
for rev in "$base" "$new"; do
  c=$(git rev-parse --short "$rev")
  revs+=("$c")
  git worktree add --force --detach "$work/src" "$rev" >/dev/null 2>&1
  (cd "$work/src" && cargo build --release --quiet --bin nerf --target-dir "$tdir/parts-native")
  cp "$tdir/parts-native/release/nerf" "$work/nerf-$c"
  (cd "$work/src" && RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin nerf --target-dir "$tdir/v3")
  cp "$tdir/v3/release/nerf" "$work/nerf-v3-$c"
  git worktree remove --force "$work/src"
  "$work/nerf-$c" export "$model" --bits 8 --out "$work/int8-$c.nerf" >&2
done
field() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$1" "$2"; }
echo "commit,file_bytes,format_version,psnr,ssim,us_per_ray_round1,us_per_ray_round2,us_per_ray_round3,instructions_per_ray"
declare -A us
for round in 1 2 3; do
  for c in "${revs[@]}"; do
    "$work/nerf-$c" eval "$work/int8-$c.nerf" --data "$root/lego" --split val --threads 1 --early-stop 1e-3 \
      --repeat 5 > "$work/eval-$c-$round.json"
    us[$c,$round]=$(printf '%.3f' "$(field "$work/eval-$c-$round.json" us_per_ray)")
  done
done
for c in "${revs[@]}"; do
  out="$work/cg.$c"
  valgrind --tool=callgrind --callgrind-out-file="$out" --toggle-collect='*render_view*' "$work/nerf-v3-$c" eval \
    "$work/int8-$c.nerf" --data "$root/lego" --split val --downscale 40 --threads 1 --early-stop 1e-3 \
    > /dev/null 2>&1
  callgrind_annotate "$out" > "$out.txt" 2>/dev/null
  ir=$(awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1; exit}' "$out.txt")
  bytes=$(stat -c %s "$work/int8-$c.nerf")
  version=$(od -An -tu2 -j4 -N2 "$work/int8-$c.nerf" | tr -d ' ')
  e="$work/eval-$c-1.json"
  printf '%s,%s,%s,%.3f,%.4f,%s,%s,%s,%s\n' "$c" "$bytes" "$version" "$(field "$e" psnr)" "$(field "$e" ssim)" \
    "${us[$c,1]}" "${us[$c,2]}" "${us[$c,3]}" "$((ir / 4000))"
done
c=${revs[1]}
"$work/nerf-$c" eval "$model" --data "$root/lego" --split val --threads 1 --early-stop 1e-3 > "$work/f32.json"
printf 'f32,%s,,%.3f,%.4f,,,,\n' "$(stat -c %s "$model")" "$(field "$work/f32.json" psnr)" "$(field "$work/f32.json" ssim)"
if [ "$layers" = "--layers" ]; then
  echo "layer_at_int8_precision,psnr"
  n=$("$work/nerf-$c" info "$model" --json | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["coarse"]["layers"]))')
  for l in $(seq 0 $((n - 1))) "$(seq -s, 0 $((n - 1)))"; do
    "$work/nerf-$c" export "$model" --bits 16 --int8-layers "$l" --out "$work/l.nerf" --force >&2
    "$work/nerf-$c" eval "$work/l.nerf" --data "$root/lego" --split val --early-stop 1e-3 > "$work/l.json"
    printf '"%s",%.3f\n' "$l" "$(field "$work/l.json" psnr)"
  done
fi
