# URB top-level build. The two commands a newcomer needs:
#   make demo    the main job
#   make check   the whole test suite (what CI runs)
# Each concern adds its own targets in mk/<concern>.mk and appends the ones that guard
# correctness to CHECK_TARGETS.

SHELL := /bin/bash
# Every target runs the project's virtual environment (.venv/, made by tools/setup.sh): its python3,
# urb and pytest come first on PATH, for the recipes and for every program they start.
VENV := $(CURDIR)/.venv
export VIRTUAL_ENV := $(VENV)
export PATH := $(VENV)/bin:$(PATH)
PYTHON := python3
PYTEST := tools/run-pytest
CHECK_TARGETS :=

.DEFAULT_GOAL := help
.PHONY: help setup gen gen-check accel host-c-py lint test-py check demo bench clean

help:
	@echo "make demo       run the main job (installs what is missing first)"
	@echo "make check      run every check CI runs (installs what is missing first)"
	@echo "make gen        regenerate gen/c and gen/python from spec/schema"
	@echo "make gen-check  fail when the committed generated files are stale"
	@echo "make accel      build urb_msgs._accel, the Python message classes' C codecs (from gen/c)"
	@echo "make host-c-py  build urb.managers._native, the Python host library's protocol cores on host/c/core"
	@echo "make bench      run the benchmarks: codecs next to MAVLink, host library CPU per request, C next to Python"
	@echo "make report     the certification evidence report: build/report/index.html and report.pdf"

setup:
	@tools/setup.sh

gen: setup
	urb gen

gen-check: setup
	urb gen --check

# The accelerated codecs of the generated Python classes: gen/python/urb_msgs/_accel.c with gen/c,
# compiled for .venv's interpreter (a build product, git-ignored; rebuilt when a source is newer).
# urb_msgs picks them when built; URB_PURE_PYTHON=1 keeps the pure-Python reference codecs.
accel: setup
	$(PYTHON) -m urb_codegen.build_accel

# The Python host library's protocol cores on the C core of host/c (host/urb/managers/native.py):
# host/urb/managers/_native.c with host/c/core, compiled for .venv's interpreter (a build product,
# git-ignored; rebuilt when its sources' digest changes). The managers pick it when built;
# URB_PURE_PYTHON=1 keeps the Python reference cores (and codecs).
host-c-py: setup
	$(PYTHON) tools/build_native_core.py

lint: setup
	$(PYTHON) -m mypy --strict host/urb codegen/urb_codegen gen/python/urb_msgs sim/urb_sim report/urb_report tools proofs/bmc/bmc_cache.py

# The Python tests run in PYTEST_WORKERS processes (pytest-xdist), each test file in one of them (its
# fixtures are shared within a file). The programs several files use are built first, so that the
# workers never build the same one at once.
# The run's JUnit XML becomes the evidence record build/evidence/pytest.json (report/urb_report/junit.py),
# written whether the tests passed or not; hypothesis draws from PYTEST_SEED, so the same commit and
# seed give the same examples and verdicts.
PYTEST_WORKERS ?= 2
PYTEST_SEED ?= 0
PYTEST_PY_ARGS := -q -n $(PYTEST_WORKERS) --dist loadfile tests --ignore=tests/test_c_codecs.py --hypothesis-seed=$(PYTEST_SEED)
test-py: setup accel host-c-py sim-lib bridge-hosted
	@rm -f build/evidence/pytest.json build/junit/pytest.xml
	$(PYTEST) $(PYTEST_PY_ARGS) --junitxml=build/junit/pytest.xml -o junit_family=xunit1; status=$$?; \
	$(PYTHON) -m urb_report.junit pytest build/junit/pytest.xml --name pytest --seed $(PYTEST_SEED) \
	  --args "pytest $(PYTEST_PY_ARGS)" || status=1; exit $$status

include $(wildcard mk/*.mk)

# The report gate runs last, once every target above has written its evidence record.
check: setup gen-check lint test-py $(CHECK_TARGETS)
	@$(MAKE) --no-print-directory report-gate
	@echo "make check: all checks passed"

demo: setup accel host-c-py
	urb sim sensorhex --sensitivity

bench: setup accel host-c-py bridge-hosted host-c-bench
	$(PYTHON) bench/codec_bench.py
	URB_HOST_CORE=python $(PYTHON) bench/host_cpu.py --json build/bench/host_cpu.json
	URB_HOST_CORE=c $(PYTHON) bench/host_cpu.py --json build/bench/host_cpu_native.json
	URB_HOST_CORE=c $(PYTHON) bench/host_cpu_sensorhex.py
	$(PYTHON) bench/host_cpu_c.py

clean:
	rm -rf build
