# samplehd: `make demo` and `make test` set up everything they need on a fresh Debian machine.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEV_STAMP := $(VENV)/.installed-dev
PYTEST_ARGS ?= -m "not slow"

.PHONY: demo test test-all bench lint gl clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(DEV_STAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[dev,ray]"
	touch $@

gl:
	@bash scripts/ensure-gl.sh

demo: gl $(STAMP)
	$(BIN)/samplehd demo --out outputs/demo

test: gl $(DEV_STAMP)
	$(BIN)/python -m pytest $(PYTEST_ARGS)

test-all: gl $(DEV_STAMP)
	$(BIN)/python -m pytest

bench: gl $(STAMP)
	$(BIN)/samplehd bench --out outputs/bench

lint: $(DEV_STAMP)
	$(BIN)/ruff check src tests benchmarks

clean:
	rm -rf $(VENV) outputs build src/*.egg-info
