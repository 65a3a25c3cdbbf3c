"""The daemon's live map on loopback: what /api/tracks and /api/status say is what the daemon knows."""

from __future__ import annotations

import json
import math
import threading
import time
import urllib.error
import urllib.request

import pytest

from gcs.engine.tracker_factory import horizon_steps, scenario_planner
from gcs.adapters.web.server import LiveMapServer
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

RATE = 5.0
EPOCH_NS = 1_000_000_000_000


def _get(url: str) -> dict:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return json.loads(answer.read())


def test_the_map_shows_the_daemons_vehicles_track_plans_and_counters_then_goes_away_with_it() -> None:
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(
        zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()), http=("127.0.0.1", 0),
        mavlink={v.id: ANY_UDP for v in SCENARIO.vehicles}))
    daemon.open()
    endpoint, port = daemon_ports(daemon)
    assert daemon.live is not None
    url = daemon.live.url
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    try:
        with running_vehicles(options(port, rate=RATE, zenoh=ZenohSettings(connect=(endpoint,)), epoch_ns=EPOCH_NS,
                                      wait_for_subscriber_s=5)):
            wait_until(lambda: daemon.counters["decisions"] >= 5, 30, "5 decisions")
            wait_until(lambda: (_get(url + "api/status")["counters"].get("decisions", 0) >= 5), 5, "a newer snapshot")
            tracks, status = _get(url + "api/tracks"), _get(url + "api/status")
    finally:
        daemon.stop()
        thread.join(timeout=15)
    assert not thread.is_alive()
    assert [v["id"] for v in tracks["vehicles"]] == ["uav1", "uav2", "uav3"]
    for vehicle in tracks["vehicles"]:
        entry = daemon.registry.entries[vehicle["id"]]
        assert vehicle["link"] == "ok" and 5 <= vehicle["reports"] <= entry.reports
        assert vehicle["stamp_ns"] <= entry.nav_stamp_ns  # placed from GPS at the nav rate
        # the flight (at 25 m/s) between the two stamps, and GPS noise, apart
        assert math.dist((vehicle["x"], vehicle["y"]), entry.position_enu_m[:2]) < 25.0 * (
            1.0 + abs(entry.position_stamp_ns - vehicle["stamp_ns"]) / 1e9)
        assert len(vehicle["plan"]) == horizon_steps(SCENARIO, scenario_planner(SCENARIO)) and len(vehicle["trail"]) >= 3
    (track,) = tracks["tracks"]
    assert track["seq"] <= daemon.loop.track_seq and track["seq"] >= 4
    assert len(track["prediction"]) == horizon_steps(SCENARIO, scenario_planner(SCENARIO)) and track["ellipse"]["rx"] > 0
    assert status["mode"] == "live" and status["scenario"] == SCENARIO.name
    assert status["counters"]["decisions"] <= daemon.counters["decisions"]
    assert status["counters"]["accepted.report"] >= 15 and status["rmse_m"] > 0  # the simulator publishes truth
    assert [v["autopilot"] for v in status["vehicles"]] == ["ArduPilot"] * 3
    with pytest.raises(urllib.error.URLError):  # closed with the daemon
        _get(url + "api/status")


def test_a_busy_address_leaves_the_daemon_running_without_a_map() -> None:
    busy = LiveMapServer(("127.0.0.1", 0), b"{}")
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
                                                   http=("127.0.0.1", busy.port)))
    try:
        daemon.run(until=lambda: daemon.counters["errors.live_map_open"] > 0 and time.sleep(0.2) is None)
    finally:
        busy.close()
    assert daemon.live is None and daemon.counters["errors.live_map_open"] == 1
