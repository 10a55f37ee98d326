#!/usr/bin/env bash
# The whole-pitch study (docs/whole_pitch_study.md): the compact single-frame and late-fusion detectors over the whole
# pitch ([-56, 56] x [-38, 38] m, train/configs/whole_pitch/) on the best Mid-100 rig (two behind the goals) and on
# the paper's one-sensor rig, the same match; Table 1 (early fusion fitted after the study), Table 2, AP and Table 2
# by pitch zone.
# Usage: studies/whole_pitch/run.sh DATASETS OUT [ITERATIONS]   (run from the repository root)
set -euo pipefail
datasets=$1 out=$2 iterations=${3:-500}
for scenario in whole_mid100_goals_snapshot_track_sizes paper_x1_snapshot_track_sizes; do
  run=$out/$scenario
  simgen-train study scenarios/$scenario.yaml --configs train/configs/whole_pitch --models single,late \
    --iterations "$iterations" --datasets "$datasets" -o "$run" --workers 1 --device cpu
  simgen-train table2 "$run"/late/tracklets/*.npz --dataset "$datasets/$scenario" \
    --config train/configs/whole_pitch/late.yaml --filters-from "$run/table2.csv" --by-zone -o "$run/zones" --quiet
  for model in single late; do
    simgen-train eval "$run/$model/checkpoint.pt" --dataset "$datasets/$scenario" --split val --by-zone \
      --by-distance -o "$run/$model/ap" --device cpu --quiet
  done
  # early fusion, added after the study at the same budget and seed (the study's early would be this fit)
  simgen-train fit train/configs/whole_pitch/early.yaml --dataset "$datasets/$scenario" -o "$run/early" \
    --iterations "$iterations" --workers 1 --device cpu --quiet --overwrite
  simgen-train eval "$run/early/checkpoint.pt" --dataset "$datasets/$scenario" --split val --by-zone \
    --by-distance -o "$run/early/ap" --device cpu --quiet
done
