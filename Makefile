# One entry point for people and CI. Every target sets up what it needs on a fresh machine.
VENV      ?= .venv
PY        := $(VENV)/bin/python
STAMP     := $(VENV)/.installed
PEERS     ?= .venv-peers
ARGS      ?=
# Test workers (pytest-xdist): one per core; JOBS=0 runs the tests in this process.
JOBS      ?= auto

.PHONY: run test durations bench chromium snapshots lint clean

run: $(STAMP)          ## set up and start the interactive planner
	$(PY) -m app $(ARGS)

test: $(STAMP) chromium  ## set up (venv + Chromium) and run the whole test suite
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile --no-loadscope-reorder $(ARGS)

durations: $(STAMP) chromium  ## run the suite and record each module's seconds (slowest run first)
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile --no-loadscope-reorder --junitxml=.durations.xml $(ARGS)
	$(PY) tools/durations.py .durations.xml

snapshots: $(STAMP) chromium  ## re-render the golden PNGs after an intended visual change
	UPDATE_SNAPSHOTS=1 $(PY) -m pytest -q tests/test_snapshots.py

bench: $(STAMP) $(PEERS)/.installed  ## benchmarks against pyvisgraph and extremitypathfinder
	$(PY) tests/benchmarks/run.py --peers-python $(PEERS)/bin/python $(ARGS)

lint: $(STAMP)
	$(VENV)/bin/pip install -q ruff pyright
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check . && $(VENV)/bin/pyright

chromium:
	@bash tools/ensure-chromium.sh

$(STAMP): pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test]'
	$(PY) -c 'import planners.kernels as k, planners.maps as m; k.warm_up(); m.warm_up()'  # compile the loops once (about 30 s)
	touch $@

# The peers pin numpy<2, so they live in their own environment; the project never imports them.
# pyvisgraph imports tqdm without declaring it.
$(PEERS)/.installed:
	python3 -m venv $(PEERS)
	$(PEERS)/bin/pip install -q pyvisgraph tqdm extremitypathfinder "numpy<2" shapely
	touch $@

clean:
	rm -rf $(VENV) $(PEERS)
