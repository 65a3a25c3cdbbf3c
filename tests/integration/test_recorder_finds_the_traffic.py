"""``gcs record`` with no endpoint given goes where the traffic is (loopback Zenoh, in process).

The command finds it on ``tcp/127.0.0.1:7447``; these tests give it a port the system
chose instead (bound on port 0, read back, let go), so that they never meet anything
else on this machine: nobody listening there (it listens, a router, and the vehicles
and a daemon that joins it hear each other through it), somebody (it joins), or a port
another program holds (it says it could do neither).
"""

from __future__ import annotations

import queue
import re
import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.recordings.record import Recording, RecordSettings, record
from protocols.keys import reports_selector
from sim_vehicles.run_options import RunOptions
from tests.integration.sim_harness import SCENARIO, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, LOCALHOST, silent_port

VEHICLES = [v.id for v in SCENARIO.vehicles]


def _free_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind((LOCALHOST, 0))
        return f"tcp/{LOCALHOST}:{probe.getsockname()[1]}"


@contextmanager
def _recording(endpoint: str, output) -> Iterator[tuple[queue.Queue, list[Recording]]]:
    """``record`` as the command runs it without endpoints (``find``), on ``endpoint``, in a thread; its
    lines, and what it recorded once stopped."""
    lines: queue.Queue = queue.Queue()
    held: list[Recording] = []
    stop = threading.Event()
    where = RecordSettings(ZenohSettings(mode="client", connect=(endpoint,)), find=True)
    thread = threading.Thread(target=lambda: held.append(record(where, "gcs", output, stop, announce=lines.put)))
    thread.start()
    try:
        yield lines, held
    finally:
        stop.set()
        thread.join(30)
        assert not thread.is_alive(), "the recorder did not stop"


def _wait_for(lines: queue.Queue, pattern: str, seen: list[str]) -> re.Match:
    while True:
        line = lines.get(timeout=60)
        seen.append(line)
        if match := re.search(pattern, line):
            return match


def test_with_nobody_there_it_is_the_meeting_point_for_the_vehicles_and_a_daemon_joining_it(tmp_path) -> None:
    endpoint, output = _free_endpoint(), tmp_path / "run.mcap"
    joined: list[str] = []
    seen: list[str] = []
    with _recording(endpoint, output) as (lines, held):
        _wait_for(lines, rf"as a zenoh router; listening on {endpoint} \(nobody listened there", seen)
        with open_session(ZenohSettings(mode="client", connect=(endpoint,))) as daemon_like:  # gcs run joining it
            daemon_like.declare_subscriber(reports_selector(), lambda s: joined.append(str(s.key_expr)))
            with running_vehicles(RunOptions(rate=10.0, duration_s=10.0, zenoh=ZenohSettings(connect=(endpoint,)),
                                             wait_for_subscriber_s=30.0)) as runner:
                for _ in VEHICLES:  # each leaves after everything it published: all of it is in
                    _wait_for(lines, r"^vehicle \w+ left$", seen)
                reports = sum(runner.summary.reports.values())
            wait_until(lambda: len(joined) == reports, 10, "the joined client to hear every report")
    (recording,) = held
    assert reports == 30 and recording.reports == reports and sorted(recording.vehicles) == VEHICLES
    assert recording.scenario.scenario == SCENARIO.name
    assert [line for line in seen if line.startswith("hearing vehicle")] == [f"hearing vehicle {v}" for v in VEHICLES]
    assert sum(r.key.endswith("/report") for r in read_recording(output)) == reports


def test_with_somebody_there_it_joins_as_a_client_and_hears_what_reaches_them(tmp_path) -> None:
    output = tmp_path / "beside.mcap"
    with open_session(ZenohSettings(mode="peer", listen=(ANY_PORT_ENDPOINT,), connect=())) as daemon_like:
        (endpoint,) = listening_endpoints(daemon_like)
        seen: list[str] = []
        with _recording(endpoint, output) as (lines, held):
            _wait_for(lines, rf"as a zenoh client; joined {endpoint} \(the daemon or router there forwards", seen)
            with running_vehicles(RunOptions(rate=10.0, duration_s=10.0, zenoh=ZenohSettings(connect=(endpoint,)),
                                             wait_for_subscriber_s=30.0)) as runner:
                for _ in VEHICLES:
                    _wait_for(lines, r"^vehicle \w+ left$", seen)
                reports = sum(runner.summary.reports.values())
    (recording,) = held
    assert reports == 30 and recording.reports == reports and sorted(recording.vehicles) == VEHICLES


def test_where_it_can_neither_join_nor_listen_it_says_both(tmp_path) -> None:
    with silent_port() as port:  # bound by another program, never listened on: refused, and taken
        endpoint = f"tcp/{LOCALHOST}:{port}"
        where = RecordSettings(ZenohSettings(mode="client", connect=(endpoint,)), find=True)
        with pytest.raises(RuntimeError, match=rf"cannot join {endpoint} \(.+\) nor listen there \(.+\)"):
            record(where, "gcs", tmp_path / "none.mcap", threading.Event())
