#!/usr/bin/env bash
# Reruns the named measurements, then writes docs/RESULTS.md and the
# README's results table from the CSV files they append to
# (scripts/lib/results_md.py). Without a name it only rewrites the two from
# the rows already recorded.
#
#   scripts/results.sh [--data DATA_ROOT] [NAME...|all]
#   scripts/results.sh --list
#
# DATA_ROOT holds lego/, bird/ and fox/ (default ../shared/data). Each
# measurement builds the release binary first; those that need QEMU or
# Chromium install or ask for them (see the scripts).
set -euo pipefail
cd "$(dirname "$0")/.."
root=../shared/data
names=()
# name|minutes on 2 cores|command
steps=(
  "default|25|scripts/measure/lego_default.sh ROOT 10 0 1 && scripts/measure/lego_default.sh ROOT 1 0 1"
  "full|95|scripts/measure/lego_full.sh ROOT 90 1"
  "paper|90|scripts/measure/paper_table.sh ROOT/flower 20 ROOT/lego 60"
  "paper-configs|65|scripts/measure/paper_configs.sh ROOT/flower 7400 '{}' '{\"features\": {\"width\": 4}}' '{\"features\": {\"levels\": 16}}' '{\"sampling\": {\"proposal_res\": 128, \"n_coarse\": 128}, \"loss\": {\"distortion\": 0.001}}'"
  "paper-screen|70|scripts/measure/paper_configs.sh ROOT/flower 3000 '{}' '{\"optimiser\": {\"lr\": 0.02}}' '{\"optimiser\": {\"lr\": 0.03}}' '{\"features\": {\"max_res\": 2048}}' '{\"sampling\": {\"n_main\": 24}}' '{\"loss\": {\"distortion\": 0.01}}' && scripts/measure/paper_configs.sh ROOT/flower 25601 '{\"optimiser\": {\"lr\": 0.02}}'"
  "tradeoff|12|scripts/measure/tradeoff.sh ROOT 10"
  "fast-int8|35|scripts/measure/fast_int8.sh ROOT 60000"
  "int8-loss|15|scripts/measure/int8_loss.sh ROOT 3"
  "table-bits|12|scripts/measure/table_bits.sh ROOT 10"
  "captures|40|scripts/measure/captures.sh ROOT 5"
  "baseline-rerun|30|scripts/measure/baseline_rerun.sh ROOT 5"
  "lens|12|scripts/measure/lens.sh ROOT 1000 0 && scripts/measure/lens.sh ROOT 1000 1"
  "scene360|5|scripts/measure/scene360.sh 2"
  "proposal|70|BASELINE=1 scripts/measure/proposal.sh ROOT 5"
  "main-samples|65|scripts/measure/main_samples.sh ROOT 5 16 32"
  "capture-ab|40|scripts/measure/capture_ab.sh ROOT/fox 2500 '{}' '{\"appearance\": true}' '{\"distortion\": 0.001}' && scripts/measure/capture_ab.sh ROOT/bird 2500 '{}' '{\"appearance\": true}' '{\"distortion\": 0.001}' && scripts/measure/capture_ab.sh ROOT/bird 5m '{}' '{\"n_coarse\": 192, \"n_main\": 48}' && scripts/measure/capture_ab.sh ROOT/fox 5m '{}' '{\"n_coarse\": 192, \"n_main\": 48}' && scripts/measure/capture_ab.sh ROOT/lego 5m '{}'"
  "capture-ff|20|scripts/measure/capture_ab.sh llff 3000 '{}' '{\"distortion\": 0.001}' && scripts/measure/capture_ab.sh llff 5m '{}' '{\"distortion\": 0.001}'"
  "capture-5m|55|for c in ROOT/bird ROOT/fox; do scripts/measure/capture_ab.sh \$c 5m '{}' '{\"distortion\": 0.001}' '{\"n_main\": 16}'; done && scripts/measure/capture_ab.sh room 5m '{}' '{\"distortion\": 0.001}' '{\"n_coarse\": 192, \"n_main\": 48}'"
  "capture-pose|35|for c in ROOT/bird ROOT/fox; do scripts/measure/capture_ab.sh \$c 2000 '{}' '{\"pose_refine\": true, \"pose_lr\": 1e-4}' '{\"pose_refine\": true, \"pose_lr\": 6e-4}'; done && scripts/measure/pose_perturbed.sh ROOT 2000 0.5 0.01"
  "masks|15|scripts/measure/masks.sh ROOT/fox 2000 && scripts/measure/masks.sh ROOT/bird 2000"
  "room-region|17|scripts/measure/room_region.sh 5m 0 '{}' '{\"feature_max_res\": 1024}'"
  "seeds|10|scripts/measure/seeds.sh room 1000 0 1 2 3 4 5 6 7"
  "layouts|20|scripts/measure/layouts.sh ROOT 1500 && scripts/measure/capture_bird.sh ROOT 1500"
  "plain-build|12|scripts/measure/plain_build_lego.sh ROOT 10"
  "ray-stages|25|scripts/measure/ray_stages_default.sh ROOT 3"
  "bench|12|scripts/measure/bench.sh"
  "step|3|scripts/measure/train_step.sh ROOT 3000 features grid"
  "step-sizes|8|scripts/measure/step_sizes.sh ROOT 1500 8 1"
  "mesh|12|scripts/measure/mesh.sh ROOT"
  "mcu|25|scripts/measure/mcu.sh ROOT"
  "web|13|scripts/measure/web.sh models/scene_int8.nerf 'built-in scene, int8' && scripts/measure/web.sh models/scene.nerf 'built-in scene, f32' && scripts/measure/web.sh --lego ROOT"
)
while [ $# -gt 0 ]; do
  case $1 in
    --data) root=${2:?--data needs a folder}; shift 2 ;;
    --list)
      for s in "${steps[@]}"; do IFS='|' read -r n m c <<< "$s"; printf '%-10s about %3s min   %s\n' "$n" "$m" "$c"; done
      exit 0 ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    all) for s in "${steps[@]}"; do names+=("${s%%|*}"); done; shift ;;
    *) names+=("$1"); shift ;;
  esac
done
root=$(realpath "$root")
for name in "${names[@]}"; do
  cmd=""
  for s in "${steps[@]}"; do
    IFS='|' read -r n m c <<< "$s"
    [ "$n" = "$name" ] && cmd=$c
  done
  [ -n "$cmd" ] || { echo "unknown measurement '$name' (scripts/results.sh --list names them)" >&2; exit 2; }
  echo "== $name: ${cmd//ROOT/$root}" >&2
  bash -c "set -euo pipefail; ${cmd//ROOT/\"$root\"}"
done
python3 scripts/lib/results_md.py
