# One venv, one install, two entry points: `make demo` (the main job) and `make test` (the CI suite).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
OUT ?= out/demo

.PHONY: install demo test test-slow lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,study]'
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/sparc-quad demo --out $(OUT)

test: install
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -m "not slow"

test-slow: install
	$(BIN)/python -m pytest -q -m slow

lint: install
	$(BIN)/ruff check .

# every performance script prints ratios measured in the same run and writes out/bench/<name>.json
BENCHES := control_step lcm_loop can_loop gap cosim study_scaling
bench: install
	for b in $(BENCHES); do $(BIN)/python bench/$$b.py --json out/bench/$$b.json || exit 1; done

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
