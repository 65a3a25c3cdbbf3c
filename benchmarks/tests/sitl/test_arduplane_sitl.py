"""The ground station against the real ArduPlane: three ArduPilot SITL planes taken off and taken over by the daemon,
steered along its plans, fed by the payload bridge, a link cut and restored, and the planes handed back when the
daemon stops and when the target is lost.

Each flight runs in a network namespace of its own (:func:`benchmarks.sitl.namespace.run_private`) and writes
what it measured (:mod:`benchmarks.sitl.flight`); the tests read it. The figures they hold it to come from the
scenario (the rates asked, the hand-back delay) and from what ArduPlane is documented to do, not from an earlier
run: the plane's own answers (modes, acknowledgements, stream rates) are its, and ours is to ask.
"""

from __future__ import annotations

import json
import os
import sys
from importlib import resources
from pathlib import Path

import pytest

from benchmarks.sitl.arduplane import SITL_ENV
from benchmarks.sitl.namespace import run_private

VEHICLES = ("uav1", "uav2", "uav3")
CUT = ("uav3", 60.0, 8.0)
"""The link of uav3 is cut 60 s after the target starts (about 30 s after the takeover), for 8 s."""
ASKED_HZ = 5.0  # the daemon's --stream-rate default
LINK_TIMEOUT_S = 5.0  # the daemon's: a vehicle without a HEARTBEAT for this long is lost
LEAVES_AT_S, HANDBACK_AFTER_S = 60.0, 20.0


def fly(tmp: Path, *options: str) -> dict:
    """One flight of the three planes in a namespace of its own (the seeds of :mod:`benchmarks.sitl.flight`)."""
    out = tmp / "flight.json"
    done = run_private([sys.executable, "-m", "benchmarks.sitl.flight", "--sitl", os.environ[SITL_ENV],
                        "--json", str(out), *options], timeout_s=600)
    assert done.returncode == 0, "the SITL flight failed; its log is above"
    (report,) = json.loads(out.read_text())
    return report


@pytest.fixture(scope="module")
def flight(tmp_path_factory) -> dict:
    """The default scenario: taken off by the daemon, 110 s of target, uav3's link cut once."""
    return fly(tmp_path_factory.mktemp("flight"), "--takeoff", "daemon", "--duration", "110", "--seeds", "2012",
               "--cut", *map(str, CUT))


def leaving_scenario(folder: Path) -> Path:
    """The default scenario with a target that stands among the planes, then leaves beyond every sensor's range
    at :data:`LEAVES_AT_S` (its ``[target]`` scripted)."""
    text = (resources.files("gcs.scenarios") / "wang2012_urban.toml").read_text()
    start, end = text.index("[target]"), text.index("[estimator]")
    target = ('[target]\nid = "target"\nmotion = "scripted"\n'
              f"path = [[0.0, 1500.0, 1500.0], [{LEAVES_AT_S}, 1500.0, 1500.0], [{LEAVES_AT_S + 5}, 1500.0, 15000.0],"
              " [1000.0, 1500.0, 15000.0]]\n\n")
    path = folder / "leaving.toml"
    path.write_text(text[:start] + target + text[end:])
    return path


@pytest.fixture(scope="module")
def lost_flight(tmp_path_factory) -> dict:
    """The target leaves; the daemon gives the planes back after :data:`HANDBACK_AFTER_S` without it."""
    folder = tmp_path_factory.mktemp("lost")
    return fly(folder, "--scenario", str(leaving_scenario(folder)), "--takeoff", "daemon", "--duration",
               str(LEAVES_AT_S + HANDBACK_AFTER_S + 15.0), "--handback-after", str(HANDBACK_AFTER_S))


def mode_names(report: dict, vehicle: str) -> list[str]:
    return [mode for _, mode in report["modes"][vehicle]]


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_the_daemon_arms_takes_off_and_takes_over(flight: dict, vehicle: str) -> None:
    modes, counters = mode_names(flight, vehicle), flight["mavlink"][vehicle]
    assert "TAKEOFF" in modes and "GUIDED" in modes[modes.index("TAKEOFF"):]
    assert flight["takeover_s"][vehicle] is not None
    assert counters["arm_requests"] >= 1 and counters["mode_requests"] >= 1
    # SITL refuses to arm while its pre-arm checks fail: every refusal was an arming request, nothing else
    assert counters.get("commands_rejected", 0) == counters.get("ack_failed", 0) <= counters["arm_requests"] - 1
    assert counters["positions_without_fix"] >= 1  # SITL reports lat/lon about 0 before its GPS fix: dropped


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_the_plane_is_steered_along_the_plan_and_accepts_every_command(flight: dict, vehicle: str) -> None:
    counters = flight["mavlink"][vehicle]
    flown = flight["daemon_stopped_s"] - flight["takeover_s"][vehicle]
    assert counters["heading_commands"] >= flown  # more than one a second while taken over
    assert counters["speed_commands"] >= 1 and counters["altitude_commands"] >= 1
    follow = flight["course_following"]
    assert follow["course_error_deg_median"] < 5.0  # the plan is flown, not merely acknowledged
    assert len(flight["samples"][vehicle]) > 100


@pytest.mark.parametrize("vehicle", ("uav1", "uav2"))
def test_telemetry_comes_at_the_rate_the_daemon_asks(flight: dict, vehicle: str) -> None:
    # ArduPlane streams at 1 Hz until asked (SRn_ defaults); the daemon asks 5 Hz on its own port
    for name, hz in flight["streams_hz"][vehicle].items():
        assert hz == pytest.approx(ASKED_HZ, rel=0.1), name


def test_a_cut_link_is_noticed_and_the_plane_is_steered_again_when_it_returns(flight: dict) -> None:
    vehicle, at_s, for_s = CUT
    events, counters, before = flight["cut"], flight["mavlink"][vehicle], flight["mavlink_at_restore"]
    assert at_s <= events["cut_s"] < events["lost_s"] <= events["cut_s"] + LINK_TIMEOUT_S + 1.5
    assert events["restored_s"] <= events["up_again_s"] <= events["restored_s"] + 3.0
    assert flight["connects"][vehicle] == 2 and counters["link_lost"] == 1 and counters["link_up"] == 2
    assert counters["stream_requests"] > before["stream_requests"]  # its telemetry asked for again
    assert counters["ack_accepted"] > before["ack_accepted"] + 10  # steered again, and the plane obeys
    assert mode_names(flight, vehicle)[-1] == "LOITER"


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_the_planes_are_handed_back_in_loiter_when_the_daemon_stops(flight: dict, vehicle: str) -> None:
    modes = flight["modes"][vehicle]
    guided = [t for t, mode in modes if mode == "GUIDED"]
    assert modes[-1][1] == "LOITER" and modes[-1][0] >= flight["daemon_stopped_s"] - 1.0 > guided[-1]
    assert flight["mavlink"][vehicle]["handbacks"] == 1


def test_three_planes_and_the_payload_bridge_track_the_target(flight: dict) -> None:
    summary = flight["summary"]
    assert summary["steps"] >= 100  # a decision a second, from the reports the bridge publishes
    assert all(summary["seen_per_uav"][v] > 0 for v in VEHICLES)
    assert summary["seen_any"] > summary["steps"] / 2
    assert summary["rmse_m"] < 50.0  # the fused track is on the target (sensor errors 10 m, 0.05 rad)


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_the_planes_are_handed_back_when_the_target_is_lost(lost_flight: dict, vehicle: str) -> None:
    modes = lost_flight["modes"][vehicle]
    assert modes[-1][1] == "LOITER"
    assert LEAVES_AT_S + HANDBACK_AFTER_S - 1.0 <= modes[-1][0] < lost_flight["daemon_stopped_s"]
    assert lost_flight["mavlink"][vehicle]["handbacks"] >= 1
