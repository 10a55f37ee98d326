#!/usr/bin/env bash
# The paper-size study on the lent GPU machine (tools `device`), in the steps it was run.
# That machine has torch but no football engine, pydantic or mcap and reaches no registry: the
# dataset is made here (`make setup`, `simgen generate scenarios/paper_x1.yaml`), packed to 1 mm
# (`python -m simgen.datasets.compact pack datasets/paper_x1 .gpu/paper_x1`, 154 -> 59 MB) and
# carried in two calls with the missing wheels (.whl/, cp312); what a call carries is copied to /tmp,
# since the next call's working tree is fresh. Usage on the device: device.sh STEP [SECONDS].
set -euo pipefail
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
models=(late single early)

case "$1" in
  install)   # call 1 carries .whl and the points of clips 0-1
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl
    mkdir -p /tmp/packed && cp -r .gpu/paper_x1 /tmp/packed/
    python3 -c "import torch, train.cli, train.study; print(torch.__version__, torch.cuda.get_device_name(0))" ;;
  fit)       # call 2 carries the rest; the three detectors train side by side in the background
    cp -r .gpu/paper_x1 /tmp/packed/ && python3 -m simgen.datasets.compact unpack /tmp/packed/paper_x1 /tmp/datasets/paper_x1
    for m in "${models[@]}"; do
      setsid nohup python3 -m train.cli fit "train/configs/paper/$m.yaml" --dataset /tmp/datasets/paper_x1 -o "/tmp/study/$m" \
        >"/tmp/fit_$m.log" 2>&1 </dev/null &
    done
    sleep "${2:-540}" ;;
  wait)      # hold the machine until the fits are done (or SECONDS pass)
    end=$((SECONDS + ${2:-540}))
    while pgrep -f "train.cli fit" >/dev/null && [ $SECONDS -lt $end ]; do sleep 5; done ;;
  tables)    # the study reuses the three checkpoints (marked as fitted on this dataset): Tables 1 and 2
    python3 - <<'PY'
import json
from pathlib import Path
from simgen.scenario import load_scenario
marker = {"dataset": "/tmp/datasets/paper_x1", "scenario": load_scenario("scenarios/paper_x1.yaml").model_dump(mode="json")}
for model in ("late", "single", "early"):
    Path(f"/tmp/study/{model}/trained_on.json").write_text(json.dumps(marker, sort_keys=True))
PY
    timeout "${2:-500}" python3 -m train.cli study scenarios/paper_x1.yaml --configs train/configs/paper --datasets /tmp/datasets \
      -o /tmp/study --models late,single,early >/tmp/study.log 2>&1 || echo "study: exit $?" ;;
  fetch)     # tables, curves and logs; the late weights in parts under 16 MiB
    tar czf "$OUT/study.tgz" --exclude checkpoint.pt --exclude tracklets -C /tmp study $(cd /tmp && ls fit_*.log study.log 2>/dev/null)
    python3 -c "import torch; c = torch.load('/tmp/study/late/checkpoint.pt', weights_only=True); c['optimizer'] = None; torch.save(c, '/tmp/late_weights.pt')"
    split -b 15M /tmp/late_weights.pt "$OUT/late_weights.pt.part-" ;;
esac
for log in /tmp/fit_*.log /tmp/study.log; do
  [ -f "$log" ] && { echo "== $log"; tr '\r' '\n' <"$log" | grep -v '^\s*$' | tail -3; }
done
nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader
