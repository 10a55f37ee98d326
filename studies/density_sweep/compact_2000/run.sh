#!/usr/bin/env bash
# The compact density sweep at the configs' full 2,000 iterations x batch 2 (docs/density_sweep.md, issue 40 item 3):
# single frame and late fusion per density and training seed on the paper-like data, then AP by distance of every
# checkpoint. x1 at this budget is studies/paper_x1_snapshot_track_sizes_seeds/ (its checkpoints were not kept; seed 0
# fitted again on 2026-11-27 with the same AP, for its AP by distance: the x1 lines at the end). As run on this project's 2-core machine: seed 0 of each density on 2026-11-26 as a plain study (no
# --seed: the configs' 0) into OUT/x<d>/seed_0/; on 2026-11-27 seeds 1 and 2 of x0.25 as plain `--seed N` studies
# moved into OUT/x0_25/seed_<n>/, then the commands below, OMP_NUM_THREADS=1 and two studies side by side.
# `study --seeds` reuses the checkpoints it finds in OUT/x<d>/seed_<n>/ (the seed tables it writes for those say
# "checkpoint reused"; the committed seed_0 tables are the first run's, with its fit times) and writes the tables over
# the seeds. Seed 2 of x2, early fusion's seed 2 and x1's seeds 1 and 2 again were run on 2026-11-29 on another 2-core
# machine (Xeon with AVX-512 and AMX) that had none of the earlier checkpoints: the lines at the end. Training there is
# not bit-identical to the first machine's (the same config and seed: x0.25 seed 2 single 38.19 against 38.43 3D AP).
# Usage: studies/density_sweep/compact_2000/run.sh DATASETS OUT   (from the repository root; datasets made if missing)
set -euo pipefail
datasets=$1 out=$2
declare -A seeds=([0_25]=0,1,2 [0_5]=0,1,2 [2]=0,1)  # x2 seed 2: the end
for d in 0_25 0_5 2; do
  OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x${d}_snapshot_track_sizes.yaml -o "$out/x$d" \
    --models single,late --datasets "$datasets" --workers 1 --device cpu --seeds "${seeds[$d]}" --quiet
  for s in ${seeds[$d]//,/ }; do for m in single late; do
    OMP_NUM_THREADS=1 simgen-train eval "$out/x$d/seed_$s/$m/checkpoint.pt" \
      --dataset "$datasets/paper_x${d}_snapshot_track_sizes" --split val --by-distance -o "$out/x$d/seed_$s/$m/ap" \
      --device cpu --quiet
  done; done
done
# Early fusion, seeds 0 and 1 at x0.25 and x0.5 (committed as early/x<d>/seed_<n>/), each beside a copy of that seed's
# single and late (reused, not trained again):
for d in 0_25 0_5; do for s in 0 1; do
  mkdir -p "$out/early$s/x$d" && cp -r "$out/x$d/seed_$s" "$out/early$s/x$d/"
  OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x${d}_snapshot_track_sizes.yaml -o "$out/early$s/x$d" \
    --models single,early,late --datasets "$datasets" --workers 1 --device cpu --seeds $s --quiet
done; done
# x1 seed 0 again, for AP by distance (its ap/ folders committed into studies/paper_x1_snapshot_track_sizes_seeds/seed_0/):
OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x1_snapshot_track_sizes.yaml -o "$out/x1_seed0" \
  --models single,late --datasets "$datasets" --workers 1 --device cpu --quiet
for m in single late; do
  OMP_NUM_THREADS=1 simgen-train eval "$out/x1_seed0/$m/checkpoint.pt" --dataset "$datasets/paper_x1_snapshot_track_sizes" \
    --split val --by-distance -o "$out/x1_seed0/$m/ap" --device cpu --quiet
done
# 2026-11-29, the other machine, two lanes side by side. x2 seed 2 (its tables over seed 2 alone; over seeds 0-2 in
# docs/density_sweep.md from each seed's table1.csv and table2.csv):
OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x2_snapshot_track_sizes.yaml -o "$out/x2" --models single,late \
  --datasets "$datasets" --workers 1 --device cpu --seeds 2 --quiet
for m in single late; do
  OMP_NUM_THREADS=1 simgen-train eval "$out/x2/seed_2/$m/checkpoint.pt" --dataset "$datasets/paper_x2_snapshot_track_sizes" \
    --split val --by-distance -o "$out/x2/seed_2/$m/ap" --device cpu --quiet
done
# Early fusion seed 2 at x0.25 and x0.5 (committed as early/x<d>/seed_2/), single and late fitted beside it (seed 2's
# first checkpoints were not kept):
for d in 0_25 0_5; do
  OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x${d}_snapshot_track_sizes.yaml -o "$out/early2/x$d" \
    --models single,early,late --datasets "$datasets" --workers 1 --device cpu --seeds 2 --quiet
done
# x1 seeds 1 and 2 fitted again, for AP by distance (committed as x1_refit/seed_<n>/: table1 and the ap/ folders):
for s in 1 2; do
  OMP_NUM_THREADS=1 simgen-train study scenarios/paper_x1_snapshot_track_sizes.yaml -o "$out/x1_seed$s" \
    --models single,late --datasets "$datasets" --workers 1 --device cpu --seed $s --quiet
  for m in single late; do
    OMP_NUM_THREADS=1 simgen-train eval "$out/x1_seed$s/$m/checkpoint.pt" \
      --dataset "$datasets/paper_x1_snapshot_track_sizes" --split val --by-distance -o "$out/x1_seed$s/$m/ap" \
      --device cpu --quiet
  done
done
