# telethermo: every target installs what it needs into .venv first.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
OUT    ?= out

.PHONY: install demo test test-fast test-host test-vcan bench bench-quick stress stress-quick clean

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[plot,test,dev]'
	touch $(STAMP)

## The main job: a telepresence session of two node processes with simulated rigs.
demo: $(STAMP)
	$(VENV)/bin/telethermo session --scene sim/scenes/probe_touches_al_steel_wood.toml --out $(OUT)/session

## All tests: the host group, then the SocketCAN (vcan) group natively or inside vcan-run.
test: $(STAMP)
	scripts/run-tests

## The inner loop: no processes, no VM (tests marked `slow` or `vcan` left out; a test that starts a
## process anyway fails and says to mark it `slow`). A few minutes; `make test` is still what CI runs.
test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not vcan and not slow" --no-processes tests

test-host: $(STAMP)
	$(PY) -m pytest -q -m "not vcan" tests

test-vcan: $(STAMP)
	scripts/run-tests --vcan-only

bench: $(STAMP)
	$(PY) -m bench

bench-quick: $(STAMP)
	$(PY) -m bench --quick

stress: $(STAMP)
	$(PY) -m bench.stress

stress-quick: $(STAMP)
	$(PY) -m bench.stress --quick

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .hypothesis
