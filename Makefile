# Quick start: `make demo` (main job) and `make test` (test suite).
# Both create or reuse the local virtual environment in .venv.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
# the package alone (the demo's needs), then the test extra (torch, RotorPy, Ray, ...: the suite's)
CORE_STAMP := $(VENV)/.windnav-core
STAMP := $(VENV)/.windnav-installed

.PHONY: venv demo test quick-suite lint bench-venv clean

$(CORE_STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e .
	touch $(CORE_STAMP)

$(STAMP): $(CORE_STAMP)
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(CORE_STAMP)
	$(VENV)/bin/windnav demo --out out/demo --seed 0 --overwrite

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks

# The suite runs on TEST_WORKERS processes (pytest-xdist; 2 on the project's 2-core machine),
# idle workers taking tests from the other's queue. On an Intel Xeon, numba caches warm: 4 min
# 53 s, against 7 min 47 s in one process and 5 min 57 s one file per worker (2026-12-03).
# TEST_WORKERS=0 runs it in this one process.
TEST_WORKERS ?= 2

test: lint
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist worksteal

# the navigation benchmark's quick suite (4 variants x 8 scenarios, real winds and flights):
# a few minutes on 2 cores, so CI runs it after `make test` rather than inside it
quick-suite: $(STAMP)
	WINDNAV_QUICK_SUITE=1 $(PY) -m pytest -q tests/test_nav_benchmark.py -k quick_suite

# the benchmarks' references (pytorch_mppi, FilterPy, ...); each script in benchmarks/ runs alone
bench-venv: $(STAMP)
	$(PY) -m pip install -q -e '.[bench]'

clean:
	rm -rf $(VENV) out
