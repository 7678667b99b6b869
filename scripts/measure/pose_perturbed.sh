#!/usr/bin/env bash
# Pose refinement where the poses are known to be off: bird written in
# LLFF's layout with its training photos turned about their centres and
# moved at random (nerf-train's perturb_poses example: normal components
# of standard deviation DEGREES and SHIFT times the cameras' median
# distance from their mean; the held-out photos keep their poses), then
# compared by scripts/measure/capture_ab.sh at STEPS steps: the default, and with
# per_photo.pose_refine at its default per_photo.pose_lr (1e-4) and at 6e-4
# (nerfacto's camera optimiser's). The rows
# in docs/capture_ab.csv name the capture bird-off-DEGREES-SHIFT.
#
#   scripts/measure/pose_perturbed.sh [DATA_ROOT] [STEPS] [DEGREES] [SHIFT]
set -euo pipefail
root=$(realpath "${1:-../shared/data}")
steps_n=${2:-2000}
degrees=${3:-0.5}
shift_=${4:-0.01}
. "$(dirname "$0")/../lib/lib.sh"
cargo build --release --quiet -p nerf-train --example perturb_poses
capture="$work/bird-off-$degrees-$shift_"
target/release/examples/perturb_poses "$root/bird" "$capture" "$degrees" "$shift_"
NERF_BIN="$bin" NERF_COMMIT="$commit" scripts/measure/capture_ab.sh "$capture" "$steps_n" \
  '{}' '{"pose_refine": true, "pose_lr": 1e-4}' '{"pose_refine": true, "pose_lr": 6e-4}'
