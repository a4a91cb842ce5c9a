# Every target sets itself up: a virtual environment in .venv with exoleg and all its
# extras (Pinocchio and MuJoCo for validation, the test tools), its compiled kernels in
# numba's cache (exoleg.compile), rebuilt when pyproject.toml changes.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup browser simulate validate test bench codegen docs

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[all]'
	$(BIN)/python -m exoleg.compile
	touch $(STAMP)

simulate: setup
	$(BIN)/exoleg simulate $(ARGS)

validate: setup
	$(BIN)/exoleg validate $(ARGS)

# The operator interface's browser tests drive Debian's Chromium and its driver (packages
# chromium, chromium-driver). Installed here when missing and this user may (root with
# apt-get); otherwise those tests skip and say why.
browser:
	@if ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "make: installing Debian's chromium and chromium-driver for the browser tests"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	      chromium chromium-driver >/dev/null) || \
	      echo "make: Chromium could not be installed: the browser tests will skip"; \
	  else echo "make: no Chromium and no root to install it: the browser tests will skip"; fi; \
	fi

# The suite runs on every core (pytest-xdist), a file's tests on one worker in their order;
# on idle cores one worker more fills the third of the workers' time spent waiting on the
# wall clock (real-time sessions, the browser): tests/conftest.py's
# pytest_xdist_auto_num_workers says how much it gains and why not on a busy machine.
test: setup browser
	$(BIN)/python -m pytest -n auto --dist loadfile $(ARGS)

bench: setup
	$(BIN)/python benchmarks/bench_dynamics.py
	$(BIN)/python benchmarks/bench_simulate.py
	$(BIN)/python benchmarks/bench_device.py
	$(BIN)/python benchmarks/bench_runtime.py
	$(BIN)/python benchmarks/bench_realtime.py
	$(BIN)/python benchmarks/bench_hmi.py
	$(BIN)/python benchmarks/bench_report.py
	$(BIN)/python benchmarks/bench_sweep.py

codegen: setup
	$(BIN)/python -m exoleg.dynamics.codegen

# The documentation site in docs/_build/html: the drawn figures (docs/figures.py) and the
# guides' own pictures (their code, run as the tests run it) refreshed in docs/img first.
docs: setup
	$(BIN)/python docs/figures.py
	EXOLEG_DOCS_IMG=$(CURDIR)/docs/img $(BIN)/python -m pytest -q -n auto tests/test_docs.py -k page
	$(BIN)/python -m sphinx -W -b html docs docs/_build/html
