"""`gcs demo` keeps the simulator's output only when the simulator fails (:func:`gcs.daemon.demo.run_together`)."""

from __future__ import annotations

import logging
import sys
import tempfile

import pytest

from gcs.cli import build_parser
from gcs.daemon import demo


@pytest.mark.parametrize(("status", "kept"), [(0, False), (3, True)])
def test_the_simulators_output_is_kept_only_when_it_fails(tmp_path, monkeypatch, caplog, status: int,
                                                          kept: bool) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # the system's temporary folder, for this test
    daemon = demo.check_demo(build_parser("demo").parse_args(["demo", "--http", "none", "--plan-in", "inline"]))
    daemon.open()
    simulator = [sys.executable, "-c", f"import sys; print('simulated vehicles here'); sys.exit({status})"]
    with caplog.at_level(logging.ERROR, logger="gcs.daemon.demo"):
        assert demo.run_together(daemon, simulator) is False  # not interrupted
    left = list(tmp_path.glob("gcs-demo-sim-vehicles-*.log"))
    assert [path.read_text() for path in left] == (["simulated vehicles here\n"] if kept else [])
    if kept:
        assert f"the simulated vehicles exited with status {status}; their output is kept in {left[0]}" in caplog.text
    else:
        assert caplog.text == ""
