"""Fixtures for the integration tests: a real MAVProxy on 127.0.0.1."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.integration.mavproxy_harness import MavProxy


@pytest.fixture
def mavproxy(tmp_path: Path) -> Iterator[MavProxy]:
    """A started MAVProxy listening on ``udpin:127.0.0.1:<port>``, the system's choice (``.master_port``).

    Its logs and transcript (``mavproxy.out``) stay in the test's ``tmp_path`` for a post-mortem;
    it is stopped (SIGINT, then SIGKILL) when the test ends, pass or fail.
    """
    with MavProxy(workdir=tmp_path / "mavproxy") as proxy:
        yield proxy
