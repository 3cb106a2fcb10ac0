# The kit's three commands. Each one creates .venv from pyproject.toml on first use.
#   make lab    copy labs/ into work/ (never overwriting your files) and start JupyterLab there
#   make reset LAB=01   a fresh copy of one lab in work/, your old file kept beside it
#   make demo   the whole see-think-act loop: SLAM map of the office, then navigation on it among people
#               (PARAMS=FILE: a Nav2 parameter file for the navigation; default sim/params/uiabot_nav2_params.yaml)
#   make test   ruff, mypy, pytest (with the labs executed) and nbval on solutions/
# Instructors: make solutions re-executes solutions/ (KIT_FAST=1) and regenerates labs/.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PYTEST_ARGS ?=
# make demo ARGS="--live --speed 4": options of python -m sim demo
ARGS ?=
JUPYTER_ARGS ?=
# JupyterLab refuses to run as root unless told; containers often run as root
ROOT_FLAG := $(if $(filter 0,$(shell id -u)),--allow-root,)
export KIT_FAST ?= 1

.PHONY: lab reset demo test lint typecheck pytest nbval solutions release bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

lab: $(STAMP)
	$(BIN)/python -m grader.workdir copy
	KIT_FAST= $(BIN)/jupyter lab --notebook-dir=work $(ROOT_FLAG) $(JUPYTER_ARGS)

reset: $(STAMP)
	@test -n "$(LAB)" || { echo "usage: make reset LAB=01"; exit 2; }
	$(BIN)/python -m grader.workdir reset $(LAB)

demo: $(STAMP)
	$(BIN)/python -m sim demo --out out $(if $(PARAMS),--params $(PARAMS),) $(ARGS)

lint: $(STAMP)
	$(BIN)/ruff check kit sim grader hardware tests benchmarks

typecheck: $(STAMP)
	$(BIN)/mypy

# worksteal: a worker that runs out of tests takes some of the other's (the grading tests are
# minutes long; without it one worker can sit idle at the end). The 15 slowest tests are
# listed at the end, to keep the whole run within its budget.
pytest: $(STAMP)
	$(BIN)/pytest -n 2 --dist worksteal --durations=15 $(PYTEST_ARGS)

# nbval keeps one kernel per notebook: --dist loadscope sends each notebook whole to one worker;
# tests/nbval_sanitize.cfg normalises text that differs between machines (a zero's sign)
nbval: $(STAMP)
	$(BIN)/pytest --nbval solutions --nbval-sanitize-with tests/nbval_sanitize.cfg -n 2 \
		--dist loadscope -o addopts="" $(PYTEST_ARGS)

test: lint typecheck pytest nbval

solutions: $(STAMP)
	$(BIN)/jupyter nbconvert --to notebook --execute --inplace \
		--ExecutePreprocessor.record_timing=False solutions/[0-9][0-9]-*.ipynb
	$(BIN)/grader release

release: $(STAMP)
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
