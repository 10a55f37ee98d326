#!/usr/bin/env bash
# The compact density sweep (docs/density_sweep.md, issue 40 item 3): single frame and late fusion, the compact
# configs (train/configs/), 500 iterations x batch 2, training seeds 0, 1, 2, on the paper-like data at x0.25, x0.5,
# x1 and x2; then AP by distance of every model and seed, and the figures. As run on 2026-11-26 with two densities
# side by side (x2 then x0.25 beside x1 then x0.5) on a 2-core machine, OMP_NUM_THREADS=1 and nice -n 10.
# Usage: studies/density_sweep/compact/run.sh DATASETS OUT   (from the repository root; datasets made if missing)
set -euo pipefail
datasets=$1 out=$2
for d in 0_25 0_5 1 2; do
  OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x${d}_snapshot_track_sizes.yaml -o "$out/x$d" \
    --models late,single --iterations 500 --datasets "$datasets" --workers 1 --device cpu --seeds 0,1,2 --quiet
  for s in 0 1 2; do for m in single late; do
    OMP_NUM_THREADS=1 simgen-train eval "$out/x$d/seed_$s/$m/checkpoint.pt" \
      --dataset "$datasets/paper_x${d}_snapshot_track_sizes" --split val --by-distance -o "$out/x$d/seed_$s/$m/ap" \
      --device cpu --quiet
  done; done
done
G=studies/paper_x1_snapshot_track_sizes_gpu G2=studies/paper_x2_snapshot_track_sizes_gpu
PYTHONPATH=$PWD python scripts/density_figures.py -o studies/density_sweep \
  --curve late@1=$G/late/learning_curve.csv --curve early@1=$G/early/learning_curve.csv \
  --curve single@1=$G/single/learning_curve.csv --curve late@2=$G2/late/learning_curve.csv \
  --curve single@2=$G2/single/learning_curve.csv \
  --bins "late x1=studies/density_sweep/late_x1/ap_by_distance.csv" \
  --bins "late x2=studies/density_sweep/late_x2/ap_by_distance.csv" \
  --study 0.25="$out/x0_25" --study 0.5="$out/x0_5" --study 1="$out/x1" --study 2="$out/x2"
