# One venv, one install, two entry points: `make demo` (the main job) and `make test` (the CI suite).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
OUT ?= out/demo

.PHONY: install demo test test-unit test-slow test-reproduction lint bench clean constraints

# Everything (`.[all,dev]`), pinned by constraints.txt so a new release of a dependency cannot change the
# test environment without a commit. The robot itself needs only `pip install .` (see README).
$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[all,dev]'
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/sparc-quad demo --out $(OUT)

# the default suite on every CPU (pytest-xdist): each test file runs whole, in order, in one worker
test: install
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q -m "not slow and not reproduction" -n auto --dist loadfile

# the unit tier (under a minute): no slow studies, no multi-process or end-to-end workflow tests
test-unit: install
	$(BIN)/python -m pytest -q -m "not slow and not integration and not reproduction" -n auto --dist loadfile

test-slow: install
	$(BIN)/python -m pytest -q -m "slow and not reproduction"

# the tests that compare against the SPARC authors' own files: SPARC_AUTHORS_REPO=<a git checkout of
# github.com/YueWang996/sparc> make test-reproduction (they fail, not skip, without it)
test-reproduction: install
	$(BIN)/python -m pytest -q -m reproduction

lint: install
	$(BIN)/ruff check .

# every performance script prints ratios measured in the same run and writes out/bench/<name>.json
# CAN_LOOP_ARGS="--rt-priority 50" runs the CAN loop and its emulator SCHED_FIFO (root or CAP_SYS_NICE)
BENCHES := control_step node_tick lcm_loop can_loop gap cosim run_cost study_scaling engines
CAN_LOOP_ARGS ?=
bench: install
	for b in $(BENCHES); do $(BIN)/python bench/$$b.py --json out/bench/$$b.json \
	  $$( [ $$b = can_loop ] && echo $(CAN_LOOP_ARGS) ) || exit 1; done
	$(BIN)/python bench/summary.py out/bench

# re-pin the test environment to what the working venv has (after changing dependencies in pyproject)
constraints: install
	$(BIN)/python -m pip install --quiet -e '.[all,dev]'
	{ echo "# pip freeze of a working .venv (make constraints); used as pip install -c constraints.txt"; \
	  $(BIN)/python -m pip freeze --exclude-editable --exclude sparc-quad; } > constraints.txt

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
