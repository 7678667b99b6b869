#!/usr/bin/env bash
# A training step's time in two builds side by side: the working tree's and
# BASE's (a commit), each training the default on SCENE (a folder of
# DATA_ROOT: lego, flower, ...) at DOWNSCALE for STEPS steps
# (`--log-every STEPS`, the run's mean ms per step), alternating ROUNDS
# times so that both see the same machine; prints each run and the ratio
# of the medians (working tree / BASE), with each run's Adam stage (ms a
# step over the last STEPS steps, the parameters' average included). BASE_BIN names BASE's binary when
# it is already built (else it is built in a worktree).
#
#   scripts/check/step_ab.sh BASE [DATA_ROOT] [STEPS] [ROUNDS] [SCENE] [DOWNSCALE]
#                                  (../shared/data, 1500, 3, lego, 8)
#   BASE_BIN=old/nerf scripts/check/step_ab.sh f7466e1 ../shared/data 300 2 flower 4
set -euo pipefail
cd "$(dirname "$0")/../.."
base=${1:?give BASE, a commit}
root=${2:-../shared/data}
steps=${3:-1500}
rounds=${4:-3}
scene=${5:-lego}
downscale=${6:-8}
work=$(mktemp -d)
trap 'git worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
cargo build --release --quiet
if [ -n "${BASE_BIN:-}" ]; then
  base_bin=$(realpath "$BASE_BIN")
else
  git worktree add --detach "$work/base" "$base" >/dev/null 2>&1
  (cd "$work/base" && CARGO_TARGET_DIR="$work/target" cargo build --release --quiet)
  base_bin=$work/target/release/nerf
fi
ms() {  # BIN OUT: the run's mean ms per step
  "$1" train --data "$root/$scene" --downscale "$downscale" --iters "$steps" --val-views 0 --log-every "$steps" \
    --out "$2" >/dev/null 2>&1
  python3 -c 'import json, sys; e = json.loads(open(sys.argv[1]).read().splitlines()[-1]); print("%.3f" % (1000 * e["train_secs"] / e["step"]))' "$2/train.jsonl"
}
adam() {  # OUT: the run's ms per step in Adam (the parameters' average included)
  python3 -c 'import json, sys; e = json.loads(open(sys.argv[1]).read().splitlines()[-1]); print("%.2f" % e["step_ms"]["adam"])' "$1/train.jsonl"
}
new=(); old=()
for r in $(seq "$rounds"); do
  old+=("$(ms "$base_bin" "$work/old$r")")
  new+=("$(ms target/release/nerf "$work/new$r")")
  echo "round $r: BASE $base ${old[-1]} ms/step (Adam $(adam "$work/old$r") ms), working tree ${new[-1]} ms/step" \
    "(Adam $(adam "$work/new$r") ms)"
done
python3 - "${old[*]}" "${new[*]}" <<'PY'
import statistics, sys
old, new = ([float(v) for v in a.split()] for a in sys.argv[1:])
print(f"median: BASE {statistics.median(old):.3f}, working tree {statistics.median(new):.3f} ms/step; "
      f"ratio {statistics.median(new) / statistics.median(old):.4f}")
PY
