# Two commands for a fresh machine: `make demo` and `make test`.
# Both create .venv when it is missing and install the project with its test and cluster extras.

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# MAVProxy, the real GCS the integration tests drive (tests/integration/mavproxy_harness.py).
# Installed without its dependencies: its wheel pulls vtk, opencv and matplotlib (about
# 1 GB) for the map and 3D views; the console needs only pymavlink, defusedxml, pyserial,
# numpy and pynmeagps, which the project and its `test` extra already bring.
MAVPROXY := MAVProxy==1.8.75

.PHONY: demo test venv clean

venv: $(STAMP)

$(STAMP): pyproject.toml Makefile
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,cluster]'
	$(BIN)/python -m pip install --quiet --no-deps '$(MAVPROXY)'
	@touch $(STAMP)

# The ground station (daemon) against three simulated fixed-wings (a separate process) on
# loopback: the default scenario, 300 simulated seconds at 10x, a live line, then a summary.
demo: $(STAMP)
	$(BIN)/gcs demo

test: $(STAMP)
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .hypothesis
