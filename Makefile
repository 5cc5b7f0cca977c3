# Quick start: `make demo` (main job) and `make test` (test suite).
# Both create or reuse the local virtual environment in .venv.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.windnav-installed

.PHONY: venv demo test quick-suite lint bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/windnav demo --out out/demo --seed 0 --overwrite

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks

test: lint
	$(PY) -m pytest -q

# the navigation benchmark's quick suite (4 variants x 8 scenarios, real winds and flights):
# a few minutes on 2 cores, so CI runs it after `make test` rather than inside it
quick-suite: $(STAMP)
	WINDNAV_QUICK_SUITE=1 $(PY) -m pytest -q tests/test_nav_benchmark.py -k quick_suite

bench-venv: $(STAMP)
	$(PY) -m pip install -q -e '.[bench]'

bench: bench-venv
	$(PY) benchmarks/run_all.py

clean:
	rm -rf $(VENV) out
