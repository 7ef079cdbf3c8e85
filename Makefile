# samplehd: `make demo` and `make test` set up everything they need on a fresh Debian machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEV_STAMP := $(VENV)/.installed-dev
# Two test processes, one per core of the 2-core CI machine; a file's tests stay in one process so
# that its module fixtures are made once (TEST_WORKERS=0 runs them in this process).
TEST_WORKERS ?= 2
PYTEST_ARGS ?= -m "not slow" -n $(TEST_WORKERS) --dist loadfile

GL_DEBS := libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6
BROWSER_DEBS := chromium chromium-driver
# Mitsuba's CPU backend compiles with LLVM; Debian 12's default LLVM 15 crashes it, LLVM 19 works.
PHOTO_DEBS := libllvm19

.PHONY: demo test test-all bench bc-baseline keypose-baseline keypose-all-baseline lint gl browser photo clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[photo]"
	touch $@

# torch 2.13.0 (CPU) before the sb3 and learn extras: asked for by stable-baselines3 or the `learn`
# extra alone, pip takes a CUDA build of several GB.
$(DEV_STAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet "torch==2.13.0"
	$(BIN)/python -m pip install --quiet -e ".[dev,mesh,lerobot,ray,sb3,rerun,photo,learn]"
	touch $@

gl:
	@bash scripts/ensure-debs.sh $(GL_DEBS)

# Debian's chromium drives the web viewer's browser tests (nothing downloads a browser).
browser:
	@bash scripts/ensure-debs.sh $(BROWSER_DEBS)

# The path-traced `photo` preset (Mitsuba's LLVM backend); samplehd finds the library by itself.
photo:
	@bash scripts/ensure-debs.sh $(PHOTO_DEBS)

demo: gl photo $(STAMP)
	$(BIN)/samplehd demo --out outputs/demo

test: gl browser photo $(DEV_STAMP)
	$(BIN)/python -m pytest $(PYTEST_ARGS)

test-all: gl browser photo $(DEV_STAMP)
	$(BIN)/python -m pytest

bench: gl photo $(STAMP)
	$(BIN)/samplehd bench --out outputs/bench

# The behaviour-cloning baseline end to end (data, replay check, training, closed-loop evaluation):
# docs/BASELINES.md. Outside `make test`: it takes an hour or more on 2 cores.
bc-baseline: gl $(DEV_STAMP)
	SAMPLEHD=$(BIN)/samplehd scripts/baselines/bc.sh outputs/bc

keypose-baseline: gl $(DEV_STAMP)
	SAMPLEHD=$(BIN)/samplehd scripts/baselines/keypose.sh outputs/keypose

keypose-all-baseline: gl $(DEV_STAMP)
	SAMPLEHD=$(BIN)/samplehd scripts/baselines/keypose_all.sh outputs/keypose_all

# ruff, then the floors: import-linter's contracts in pyproject.toml (make test checks them too,
# tests/test_layers.py) and the cycle/local-import counts of scripts/import_graph.py.
lint: $(DEV_STAMP)
	$(BIN)/ruff check src tests scripts
	$(BIN)/lint-imports --no-cache
	$(BIN)/python scripts/import_graph.py

clean:
	rm -rf $(VENV) outputs build src/*.egg-info
