"""The tests against the real ArduPlane run only where its SITL binary is named by ``GCS_ARDUPLANE_SITL``
(:data:`benchmarks.sitl.arduplane.SITL_ENV`; ``.ci/run`` sets it). Elsewhere they are left out of the run, and
the summary says so in one line, with how to run them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from benchmarks.sitl.arduplane import SITL_ENV

HERE = Path(__file__).parent
_left_out: list[pytest.Item] = []


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get(SITL_ENV):
        return
    ours = [item for item in items if HERE in Path(item.fspath).parents]
    if ours:
        _left_out.extend(ours)
        config.hook.pytest_deselected(items=ours)
        items[:] = [item for item in items if item not in ours]


def pytest_terminal_summary(terminalreporter) -> None:
    if _left_out:
        terminalreporter.write_line(
            f"ArduPlane SITL tests not run ({len(_left_out)}): set {SITL_ENV}=/path/to/arduplane (ArduPilot's "
            "'./waf configure --board sitl && ./waf plane') to run them against the real autopilot")
