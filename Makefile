# Two commands do everything on a fresh Debian machine (root, no GPU):
#   make demo   set up, then capture the default scenario
#   make test   set up, then run the whole test suite
SHELL := /bin/bash
VENV := .venv
SIMGEN := $(VENV)/bin/simgen
DEMO_OUT := datasets/demo

.PHONY: setup demo test bench clean

setup:
	@bash scripts/setup.sh

demo: setup
	@mkdir -p $(DEMO_OUT)
	$(SIMGEN) validate scenarios/default.yaml
	$(SIMGEN) capture scenarios/default.yaml -o $(DEMO_OUT)/motion.parquet
	@echo "demo: the motion clip is $(DEMO_OUT)/motion.parquet (read it with simgen.motion_io.read_clip, pandas, polars or duckdb)"

test: setup
	$(VENV)/bin/python -m pytest -q

bench: setup
	@for bench in benchmarks/bench_*.py; do echo "== $$bench"; $(VENV)/bin/python $$bench || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis
