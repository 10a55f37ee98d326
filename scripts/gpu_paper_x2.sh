#!/bin/bash
# GPU driver, one command on one GPU machine (docs/gpu_study.md): the paper-size training step's speed under
# each of train.accelerate's choices (benchmarks/bench_train_cuda.py), then the paper's x2 rows (late and
# single, paper-size, 1,400 iterations x batch 8) on paper_x2_snapshot_track_sizes with the fastest choices,
# their val AP (`simgen-train eval`) and the late model's val tracklets (`simgen-train detect`) for Table 2.
#
# Runs from the repository root with the code as it is (PYTHONPATH), the GPU machine's own torch, pydantic
# and its helpers as cp312 wheels in .whl/, and the dataset packed by `simgen pack` in .gpu/x2.packed.
# Env: OUT (results), ITER (1400), BENCH_S / FIT_S / END_S (time limits, s), STEPS (timed steps per variant),
# CFG (configs folder), WORKERS (loader processes per fit), PY (the python), NO_WHEELS (use its own pydantic).
set -u
OUT=${OUT:-/tmp/gpu_out}; ITER=${ITER:-1400}; BENCH_S=${BENCH_S:-150}; FIT_S=${FIT_S:-330}; END_S=${END_S:-560}
STEPS=${STEPS:-30}; CFG=${CFG:-train/configs/paper}; WORKERS=${WORKERS:-6}; PY=${PY:-python3}
mkdir -p "$OUT"
t0=$(date +%s); el() { echo $(( $(date +%s) - t0 )); }
log() { echo "[$(el) s] $*" | tee -a "$OUT/driver.log"; }
if [ -d .whl ] && [ -z "${NO_WHEELS:-}" ] && [ ! -d /tmp/site/pydantic ]; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
fi
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
log "python $($PY --version 2>&1), torch $($PY -c 'import torch;print(torch.__version__, torch.cuda.is_available() and torch.cuda.get_device_name())' 2>&1)"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>/dev/null | tee -a "$OUT/driver.log"
D=/tmp/data/paper_x2_snapshot_track_sizes; R=/tmp/x2
if [ ! -d $D ]; then
  mkdir -p /tmp/data && $PY -m simgen.cli unpack .gpu/x2.packed -o $D 2>&1 | tail -1 | tee -a "$OUT/driver.log"
fi
[ -d $D ] || { log "unpack failed"; exit 1; }
log "dataset ready"
(command -v nvidia-smi >/dev/null && nvidia-smi dmon -s u -d 1 > "$OUT/dmon.log" 2>&1) &
dmon=$!

# 1. The step's speed, each choice added to the ones before it.
timeout "$BENCH_S" $PY benchmarks/bench_train_cuda.py --dataset $D --models late,single \
  --variants base,cudnn,channels_last --steps "$STEPS" --out "$OUT/train_cuda.md" > "$OUT/bench.log" 2>&1
log "bench exit $? "
# the fastest variant for late (base where the bench did not finish)
best=$($PY - "$OUT/bench.log" <<'EOF'
import sys
rows = [l.split(" | ") for l in open(sys.argv[1]) if l.startswith("late | ")]
print(max(rows, key=lambda r: float(r[2]))[1] if rows else "base")
EOF
)
log "fits with variant $best"

# 2. x2 late and single side by side, the configs with the chosen speed choices.
mkdir -p $R/configs
fits=()
for m in late single; do
  $PY - "$CFG/$m.yaml" "$R/configs/$m.yaml" "$best" <<'EOF'
import sys, yaml
sys.path.insert(0, "benchmarks")
from bench_train_cuda import VARIANTS
raw = yaml.safe_load(open(sys.argv[1]))
raw["train"].update(VARIANTS[sys.argv[3]])
yaml.safe_dump(raw, open(sys.argv[2], "w"), sort_keys=False)
EOF
  $PY -m train.cli fit $R/configs/$m.yaml --dataset $D -o $R/$m --iterations "$ITER" --workers "$WORKERS" \
    --stop-after "$FIT_S" > "$OUT/fit_$m.log" 2>&1 &
  fits+=($!)
done
wait "${fits[@]}"
log "fits done: $(for m in late single; do tail -1 $R/$m/train_log.csv | cut -d, -f1-3; done | tr '\n' ' ')"

# 3. Val AP of each, the late model's val tracklets.
for m in late single; do
  [ -f $R/$m/checkpoint.pt ] && timeout 60 $PY -m train.cli eval $R/$m/checkpoint.pt --dataset $D \
    -o $R/eval_$m --quiet >> "$OUT/eval.log" 2>&1
done
timeout 60 $PY -m train.cli detect $R/late/checkpoint.pt --dataset $D -o $R/detect_late --quiet >> "$OUT/eval.log" 2>&1
log "eval and detect done"
# 4. With the time left: torch.compile against channels-last alone, in the same run.
left=$(( END_S - $(el) ))
if [ $left -gt 100 ]; then
  timeout $(( left - 10 )) $PY benchmarks/bench_train_cuda.py --dataset $D --models late \
    --variants channels_last,compile --warm-up 4 --steps "$STEPS" --out "$OUT/train_cuda_compile.md" > "$OUT/bench_compile.log" 2>&1
  log "compile bench exit $?"
fi
(cd /tmp && tar --exclude='*.pt' --exclude='kitti' -czf "$OUT/x2_runs.tgz" x2)
kill $dmon 2>/dev/null
log "done"
