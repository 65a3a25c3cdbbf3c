# Two commands for a fresh machine: `make demo` and `make test`.
# Both create .venv when it is missing and install the project with its test extras.

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
	$(BIN)/python -m pip install --quiet -e '.[test]'
	$(BIN)/python -m pip install --quiet --no-deps '$(MAVPROXY)'
	@touch $(STAMP)

# Until the daemon lands (`gcs demo`), the demo checks the default scenario, runs a short
# target-estimation benchmark (DUIF vs FilterPy's UKF against the PCRLB) and one minute of
# the wang2012 closed loop in one process (GA-RHC and a stand-off orbit, same seed).
demo: $(STAMP)
	$(BIN)/gcs scenario check
	$(BIN)/gcs bench estimation --runs 20 --table-runs 2
	$(BIN)/gcs bench urban --runs 1 --duration 60 --planner ga_k5 --planner orbit --no-scaling

test: $(STAMP)
	$(BIN)/python -m pytest

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .hypothesis
