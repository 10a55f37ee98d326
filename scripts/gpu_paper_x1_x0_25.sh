#!/bin/bash
# GPU driver, one command on one GPU machine (issue 40 items 3 and 5): the whole paper-size study at x1 (late,
# single, early; Table 1 and Table 2; seed 1, a second seed beside the outside run's 0), timed as one
# `simgen-train study`, and, started LAG seconds after it, the paper-size study at x0.25 (late and single,
# the configs' seed 0; Table 1 and Table 2), both on the paper-like data (snapshot, track sizes).
#
# Runs from the repository root with the code as it is (PYTHONPATH), the GPU machine's own torch, pydantic and
# its helpers as cp312 wheels in .whl/, the datasets packed by `simgen pack` in .gpu/{x1,x0_25}.packed.
# Env: OUT (results), ITER (1400), CFG (configs folder), LAG (s), END_S (both studies stopped by then, s),
# WORKERS (loader and filter processes per study), SEED_X1, DEVICE (auto), PY (the python), NO_WHEELS.
set -u
OUT=${OUT:-/tmp/gpu_out}; ITER=${ITER:-1400}; CFG=${CFG:-train/configs/paper}; LAG=${LAG:-60}; END_S=${END_S:-560}
WORKERS=${WORKERS:-6}; SEED_X1=${SEED_X1:-1}; DEVICE=${DEVICE:-auto}; PY=${PY:-python3}
D=${DATASETS:-/tmp/datasets}; R=${RUNS:-/tmp/st}
mkdir -p "$OUT" "$D" "$R"
t0=$(date +%s); el() { echo $(( $(date +%s) - t0 )); }
log() { echo "[$(el) s] $*" | tee -a "$OUT/driver.log"; }
if [ -d .whl ] && [ -z "${NO_WHEELS:-}" ] && [ ! -d /tmp/site/pydantic ]; then
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
fi
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
log "python $($PY --version 2>&1), torch $($PY -c 'import torch;print(torch.__version__, torch.cuda.is_available() and torch.cuda.get_device_name())' 2>&1), $(nproc) CPUs"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>/dev/null | tee -a "$OUT/driver.log"
for d in x1 x0_25; do
  name=paper_${d}_snapshot_track_sizes
  [ -d $D/$name ] || $PY -m simgen.cli unpack .gpu/$d.packed -o $D/$name 2>&1 | tail -1 | tee -a "$OUT/driver.log"
  [ -d $D/$name ] || { log "unpack of $d failed"; exit 1; }
done
log "datasets ready"
(command -v nvidia-smi >/dev/null && nvidia-smi dmon -s u -d 1 > "$OUT/dmon.log" 2>&1) &
dmon=$!

study() {  # name, models, seed option, time limit (s)
  local name=$1 models=$2 seed=$3 limit=$4 began=$(el) rc
  timeout "$limit" $PY -m train.cli study scenarios/paper_${name}_snapshot_track_sizes.yaml --configs "$CFG" \
    --models "$models" --iterations "$ITER" --workers "$WORKERS" $seed --device "$DEVICE" -o "$R/$name" \
    --datasets "$D" > "$OUT/study_$name.log" 2>&1
  rc=$?
  log "study $name ($models) exit $rc after $(( $(el) - began )) s"
}
study x1 late,single,early "--seed $SEED_X1" $(( END_S - 5 )) &
x1=$!
sleep "$LAG"
log "x0.25 study starts beside the x1 study"
study x0_25 late,single "" $(( END_S - 5 - LAG )) &
wait $x1 $!
kill $dmon 2>/dev/null
for s in "$R"/*/; do
  n=$(basename "$s"); cp "$s"table1.md "$OUT/${n}_table1.md" 2>/dev/null; cp "$s"table2.md "$OUT/${n}_table2.md" 2>/dev/null
done
(cd "$R" && tar --exclude='*.pt' --exclude='kitti' -czf "$OUT/studies.tgz" .)
log "done"
