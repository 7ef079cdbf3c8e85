# samplehd: `make demo` and `make test` set up everything they need on a fresh Debian machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEV_STAMP := $(VENV)/.installed-dev
PYTEST_ARGS ?= -m "not slow"

GL_DEBS := libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6
BROWSER_DEBS := chromium chromium-driver

.PHONY: demo test test-all bench lint gl browser clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

# torch==2.13.0 first: the CPU build the `learn` extra's range then accepts (an open range would
# fetch a multi-GB CUDA build).
$(DEV_STAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet torch==2.13.0
	$(BIN)/python -m pip install --quiet -e ".[dev,ray,learn]"
	touch $@

gl:
	@bash scripts/ensure-debs.sh $(GL_DEBS)

# Debian's chromium drives the web viewer's browser tests (nothing downloads a browser).
browser:
	@bash scripts/ensure-debs.sh $(BROWSER_DEBS)

demo: gl $(STAMP)
	$(BIN)/samplehd demo --out outputs/demo

test: gl browser $(DEV_STAMP)
	$(BIN)/python -m pytest $(PYTEST_ARGS)

test-all: gl browser $(DEV_STAMP)
	$(BIN)/python -m pytest

bench: gl $(STAMP)
	$(BIN)/samplehd bench --out outputs/bench

lint: $(DEV_STAMP)
	$(BIN)/ruff check src tests benchmarks

clean:
	rm -rf $(VENV) outputs build src/*.egg-info
