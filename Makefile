# Two commands do everything on a fresh Debian machine (root, no GPU):
#   make demo   set up, then generate the default scenario's dataset
#   make test   set up, then lint (ruff) and run the whole test suite
SHELL := /bin/bash
VENV := .venv
SIMGEN := $(VENV)/bin/simgen
DEMO_OUT := datasets/demo

.PHONY: setup demo test bench lock clean

setup:
	@bash scripts/setup.sh

demo: setup
	$(SIMGEN) validate scenarios/default.yaml
	$(SIMGEN) generate scenarios/default.yaml -o $(DEMO_OUT) --overwrite
	$(SIMGEN) view $(DEMO_OUT) --frames 0:100 -o $(DEMO_OUT)_view
	@echo "demo: the dataset is in $(DEMO_OUT)/ (its README.md says what is there and how to read it);"
	@echo "      pictures and a video of its first 10 s are in $(DEMO_OUT)_view/;"
	@echo "      source $(VENV)/bin/activate puts simgen, duckdb and rerun on PATH for the README's examples"

test: setup
	$(VENV)/bin/ruff check .  # lint first (rules in pyproject.toml): a violation stops here with ruff's own message
	$(VENV)/bin/python -m pytest -q -rs  # -rs: every skip listed with its reason (none expected)

bench: setup
	@for bench in benchmarks/bench_*.py; do echo "== $$bench"; $(VENV)/bin/python $$bench || exit 1; done

lock:  # refresh requirements.lock to the newest releases pyproject.toml allows (then run make test)
	@bash scripts/lock.sh

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis
