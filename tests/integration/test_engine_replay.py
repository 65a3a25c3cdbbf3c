"""The same recorded inputs through the live daemon and through ``gcs replay --process`` give the same tracks.

One engine decides in both (:mod:`gcs.engine`): a synthetic recording of simulated vehicles
(:func:`sim_vehicles.recording.record_scene`: their liveliness tokens, reports, nav and truth) is
republished over loopback Zenoh to a daemon running in a thread, which records what it receives
and publishes; processing the daemon's recording with the options the daemon ran with gives its
tracks byte for byte. Each test changes one option that changes acceptance (``--accept-unlisted``,
``--navigation skf``, the roster, the reorder window ``--max-wait``) and checks that replaying
without it gives other tracks, so that the option really counts.
"""

from __future__ import annotations

import threading
from pathlib import Path

import msgspec
import pytest

from gcs.adapters.recording import Recorder, read_recording
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from sim_vehicles.recording import record_scene
from gcs.config.world import build_world
from gcs.recordings.replay import process, republish
from gcs.scenarios import load_scenario
from protocols.codec import encode
from tests.integration.sim_harness import wait_until
from tests.loopback import ANY_PORT_ENDPOINT, daemon_ports

pytestmark = pytest.mark.integration

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
DURATION_S = 20.0
RATE = 4.0
S = 1_000_000_000


def _with_uav4(scenario=SCENARIO):
    """The scenario with a fourth UAV, a copy of the first 300 m east of it."""
    first = scenario.vehicles[0]
    extra = msgspec.structs.replace(first, id="uav4", sysid=4, altitude_m=first.altitude_m + 30.0,
                                    start_enu_m=(first.start_enu_m[0] + 300.0, first.start_enu_m[1]))
    return msgspec.structs.replace(scenario, vehicles=[*scenario.vehicles, extra])


def _inputs(folder: Path, scenario=SCENARIO, delay_s: dict[str, float] | None = None) -> Path:
    """Simulated inputs of ``scenario``'s vehicles; each listed vehicle's reports received ``delay_s`` later."""
    path = folder / "inputs.mcap"
    record_scene(scenario, WORLD, path, duration_s=DURATION_S, seed=4)
    if not delay_s:
        return path
    rows = []
    for record in read_recording(path):
        late = next((d for v, d in delay_s.items() if record.key.endswith(f"/{v}/report")), 0.0)
        rows.append((record.log_time_ns + round(late * S), record.key, record.payload, record.encoding))
    delayed = folder / "delayed.mcap"
    with Recorder(delayed) as recorder:
        for log_time, key, payload, encoding in sorted(rows, key=lambda row: row[0]):
            recorder.write(key, payload, encoding, log_time)
    return delayed


def _live(folder: Path, inputs: Path, scenario=SCENARIO, rate: float = RATE, **options) -> tuple[Path, list[bytes],
                                                                                                  dict]:
    """Republish ``inputs`` to a daemon run with ``options``; its recording, the tracks it published, its counters."""
    recording = folder / "live.mcap"
    daemon = Daemon(scenario, WORLD, DaemonOptions(zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
                                                   record=recording, planner="pursuit", plan_runner="thread",
                                                   **options))
    daemon.open()
    endpoint, _ = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    try:
        counts = republish(inputs, ZenohSettings(connect=(endpoint,)), "gcs", rate, threading.Event())
        assert counts["report"] > 0
        wait_until(lambda: daemon.steps.open_steps == 0 and daemon.engine.released == 0, 60, "every step fused")
        counters = daemon.status(0.0).counters
    finally:
        daemon.stop()
        thread.join(timeout=15)
    assert not thread.is_alive()
    live = [r.payload for r in read_recording(recording) if "/track/" in r.key]
    assert len(live) >= DURATION_S - 3
    return recording, live, counters


def _replayed(recording: Path, scenario=SCENARIO, **options) -> list[bytes]:
    tracks, _, _ = process(recording, scenario, **options)
    return [encode(t)[0] for t in tracks]


def test_a_run_accepting_unlisted_vehicles_replays_bit_for_bit_with_accept_unlisted(tmp_path) -> None:
    inputs = _inputs(tmp_path, _with_uav4())  # uav4 is not in the roster
    recording, live, counters = _live(tmp_path, inputs, accept_unlisted=True)
    assert counters["accepted.unlisted.report"] > 0 and counters.get("rejected.late", 0) == 0, counters
    assert _replayed(recording, accept_unlisted=True) == live
    assert _replayed(recording) != live  # without it uav4's detections are rejected


def test_a_run_navigating_with_the_skf_replays_bit_for_bit_with_navigation_skf(tmp_path) -> None:
    recording, live, counters = _live(tmp_path, _inputs(tmp_path), navigation="skf")
    assert counters["nav.applied"] > 0 and counters.get("rejected.late_nav", 0) == 0, counters
    assert _replayed(recording, navigation="skf") == live
    assert _replayed(recording) != live  # auto is the reported positions on this scenario


def test_a_run_with_a_smaller_roster_replays_bit_for_bit_with_the_same_roster(tmp_path) -> None:
    pair = msgspec.structs.replace(SCENARIO, vehicles=SCENARIO.vehicles[:2])  # uav3 flies, but is not the daemon's
    recording, live, counters = _live(tmp_path, _inputs(tmp_path), pair)
    assert counters["rejected.unknown_vehicle"] > 0, counters
    assert _replayed(recording, pair) == live
    assert _replayed(recording, SCENARIO) != live  # with uav3 in the roster its detections are fused


def test_a_run_with_a_short_reorder_window_replays_bit_for_bit_with_the_same_max_wait(tmp_path) -> None:
    """uav3's reports come 0.3 s (wall) after the others': the daemon, waiting 0.05 s, fuses without them."""
    inputs = _inputs(tmp_path, delay_s={"uav3": 0.3 * 2.0})
    recording, live, counters = _live(tmp_path, inputs, rate=2.0, max_wait_s=0.05)
    assert counters["rejected.late"] > 0, counters
    assert _replayed(recording, max_wait_s=0.05) == live
    assert _replayed(recording) != live  # waiting 0.5 s, uav3's reports are in time
