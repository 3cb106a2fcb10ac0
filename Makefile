# The kit's three commands. Each one creates .venv from pyproject.toml on first use.
#   make lab    copy labs/ into work/ (never overwriting your files) and start JupyterLab there
#   make reset LAB=01   a fresh copy of one lab in work/, your old file kept beside it
#   make demo   the whole see-think-act loop: SLAM map of the office, then navigation on it among people
#               (PARAMS=FILE: a Nav2 parameter file for the navigation; default sim/params/uiabot_nav2_params.yaml;
#               ARGS=--live: watch it in Foxglove, the live view's foxglove-sdk installed the first time)
#   make test   ruff, mypy, pytest (with the labs executed) and nbval on solutions/
#   make test-loaded   the same with every core kept busy (benchmarks/stress.py)
# Instructors: make solutions re-executes solutions/ (KIT_FAST=1) and regenerates labs/.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# What each command installs, each step once (a stamp file in .venv marks it done): the kit
# and the libraries it runs on (make demo), JupyterLab (make lab), the developer tools
# (make test). Instructors and developers bootstrap everything with `make .venv/.installed`.
KIT_STAMP := $(VENV)/.kit
LAB_STAMP := $(VENV)/.lab
STAMP := $(VENV)/.installed
LIVE_STAMP := $(VENV)/.live
# --no-compile: the libraries' modules are compiled on first import, only those used
INSTALL := $(BIN)/python -m kit._pip_progress
PIP_ARGS := --no-compile
PYTEST_ARGS ?=
PYTEST_WORKERS ?= $(shell echo $$(( $$(nproc 2>/dev/null || echo 1) + 1 )))
# make demo ARGS="--live --speed 4": options of python -m sim demo
ARGS ?=
JUPYTER_ARGS ?=
# JupyterLab refuses to run as root unless told; containers often run as root
ROOT_FLAG := $(if $(filter 0,$(shell id -u)),--allow-root,)
export KIT_FAST ?= 1

.PHONY: lab reset demo test test-loaded lint typecheck warm pytest nbval solutions release bench clean

$(BIN)/python:
	@echo "make: creating the virtual environment .venv with $$($(PYTHON) --version)"
	@$(PYTHON) -m venv $(VENV)
	@echo "make: updating pip in .venv"
	@$(BIN)/python -m pip install --quiet --upgrade pip

$(KIT_STAMP): pyproject.toml | $(BIN)/python
	@$(INSTALL) "make: installing the kit and the libraries it runs on (numpy, scipy, numba, \
	pymunk, matplotlib, rosbags, ...): 1-3 min the first time" -- $(PIP_ARGS) -e .
	@touch $@

$(LAB_STAMP): pyproject.toml | $(BIN)/python
	@$(INSTALL) "make: installing the kit, the libraries it runs on and JupyterLab: 2-4 min \
	the first time" -- $(PIP_ARGS) -e ".[lab]"
	@touch $@

$(STAMP): pyproject.toml | $(BIN)/python
	@$(INSTALL) "make: installing the kit, JupyterLab and the developer tools (pytest, ruff, \
	mypy, gtsam, dask, ir-sim, ...): 3-5 min the first time" -- $(PIP_ARGS) -e ".[lab,dev]"
	@touch $@

# the live view's foxglove-sdk, for `make demo ARGS=--live` only (the developer tools have it)
$(LIVE_STAMP): pyproject.toml | $(BIN)/python
	@$(INSTALL) "make: installing the live view (foxglove-sdk) for --live" -- $(PIP_ARGS) \
	-e ".[live]"
	@touch $@

# a command that needs less is served by the most complete install already there
FOR_LAB := $(or $(wildcard $(STAMP)),$(LAB_STAMP))
FOR_KIT := $(or $(wildcard $(STAMP)),$(wildcard $(LAB_STAMP)),$(KIT_STAMP))
FOR_LIVE := $(if $(findstring --live,$(ARGS)),$(or $(wildcard $(STAMP)),$(LIVE_STAMP)),)

lab: $(FOR_LAB)
	$(BIN)/python -m grader.workdir copy
	KIT_FAST= $(BIN)/jupyter lab --notebook-dir=work $(ROOT_FLAG) $(JUPYTER_ARGS)

reset: $(FOR_KIT)
	@test -n "$(LAB)" || { echo "usage: make reset LAB=01"; exit 2; }
	$(BIN)/python -m grader.workdir reset $(LAB)

demo: $(FOR_KIT) $(FOR_LIVE)
	$(BIN)/python -m sim demo --out out $(if $(PARAMS),--params $(PARAMS),) $(ARGS)

lint: $(STAMP)
	$(BIN)/ruff check kit sim grader hardware tests benchmarks

typecheck: $(STAMP)
	$(BIN)/mypy

# pytest runs one worker more than the machine has cores (3 on 2 cores; PYTEST_WORKERS=N for
# another count): a good part of the suite waits on real time (drivers and emulators at their
# devices' rates, watchdogs, sandboxes started and killed, kernels starting), and the extra
# worker runs tests in those waits (a clean clone's make test, 2 cores: 9 min 16 s with 2
# workers, 8 min 46 s with 3). Each test process has one BLAS thread: BLAS's own threads
# could only take another worker's core, and on a busy machine they wait for it (Lab 07 run
# top to bottom with both cores busy: 27 s -> 17 s, and a third less CPU); the grader gives
# its sandboxes the same. The suite starts hundreds of Python processes (kernels, command
# lines, grading servers): each imports the scientific stack from compiled bytecode once the
# first has written it (1.6 s of CPU instead of 4.5 s for a grading server's imports), so an
# environment's PYTHONDONTWRITEBYTECODE is set empty (off) for them
TEST_ENV := PYTHONDONTWRITEBYTECODE= OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1

# worksteal: a worker that runs out of tests takes some of the other's (the grading tests are
# minutes long; without it one worker can sit idle at the end). The 15 slowest tests are
# listed at the end, to keep the whole run within its budget.
pytest: $(STAMP)
	$(TEST_ENV) $(BIN)/pytest -n $(PYTEST_WORKERS) --dist worksteal --durations=15 $(PYTEST_ARGS)

# nbval keeps one kernel per notebook: --dist loadscope sends each notebook whole to one worker;
# tests/nbval_sanitize.cfg normalises text that differs between machines (a zero's sign)
nbval: $(STAMP)
	$(TEST_ENV) $(BIN)/pytest --nbval solutions --nbval-sanitize-with tests/nbval_sanitize.cfg -n 2 \
		--dist loadscope -o addopts="" $(PYTEST_ARGS)

# warm: numba's compiled functions made once (tests/warm_caches.py) on the core ruff and mypy
# leave free, so that neither pytest worker, nor any subprocess or grading sandbox a test
# starts, compiles them again
warm: $(STAMP)
	@$(TEST_ENV) $(BIN)/python tests/warm_caches.py

test: $(STAMP)
	@$(MAKE) --no-print-directory --jobs 3 --output-sync=target lint typecheck warm
	@$(MAKE) --no-print-directory pytest nbval

# make test while benchmarks/stress.py keeps every core busy: no test may depend on the
# machine's speed (STRESS_WORKERS=N for another number of spinning processes)
STRESS_WORKERS ?=
test-loaded: $(STAMP)
	$(BIN)/python benchmarks/stress.py run $(if $(STRESS_WORKERS),--workers $(STRESS_WORKERS)) \
		-- $(MAKE) test

solutions: $(FOR_LAB)
	$(BIN)/jupyter nbconvert --to notebook --execute --inplace \
		--ExecutePreprocessor.record_timing=False solutions/[0-9][0-9]-*.ipynb
	$(BIN)/grader release

release: $(FOR_KIT)
	$(BIN)/grader release

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_core.py
	$(BIN)/python benchmarks/bench_grader.py
	$(BIN)/python benchmarks/bench_drivers.py
	$(BIN)/python benchmarks/bench_planning.py
	$(BIN)/python benchmarks/bench_slam.py
	$(BIN)/python -m sim bench

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache
