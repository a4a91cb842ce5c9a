# Every target sets itself up: a virtual environment in .venv with exoleg and all its
# extras (Pinocchio and MuJoCo for validation, the test tools), rebuilt when
# pyproject.toml changes.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup simulate validate test bench codegen

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[all]'
	touch $(STAMP)

simulate: setup
	$(BIN)/exoleg simulate $(ARGS)

validate: setup
	$(BIN)/exoleg validate $(ARGS)

test: setup
	$(BIN)/python -m pytest $(ARGS)

bench: setup
	$(BIN)/python benchmarks/bench_dynamics.py
	$(BIN)/python benchmarks/bench_simulate.py
	$(BIN)/python benchmarks/bench_device.py
	$(BIN)/python benchmarks/bench_runtime.py

codegen: setup
	$(BIN)/python -m exoleg.dynamics.codegen
