"""A real MAVProxy (PyPI 1.8.75) against the simulated vehicles, all on 127.0.0.1.

The three vehicles of the default scenario (uav1/uav2/uav3, sysids 1/2/3, in
LOITER at 200/210/220 m above home) share one socket sending to MAVProxy's
``udpin`` master port; the simulation runs at 10x real time. MAVProxy targets
the first vehicle it hears, sysid 1 (each vehicle's telemetry is sent in sysid
order), so its prompt, ``status`` and commands concern vehicle 1 until
``vehicle N`` changes the target.

Waits for the vehicles' motion are measured in simulated time
(``runner.scene.elapsed_s``), so a loaded machine that runs the simulation
late makes a test slower, not wrong.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink, open_connection
from sim_vehicles.runner import Runner
from tests.integration.mavproxy_harness import MavProxy
from tests.integration.sim_harness import SCENARIO, GroundStation, options, running_vehicles
from tests.loopback import LOCALHOST

GUIDED, LOITER, CIRCLE = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"], ARDUPLANE_MODES["CIRCLE"]
RATE = 10.0
"""Simulated seconds per wall-clock second."""
WAIT_S = 30.0
"""Every wait on MAVProxy's output (wall time): heartbeats come at 10 Hz at this rate, so a wait ends within a
fraction of a second on an idle machine; the deadline is for a loaded one, where MAVProxy prints late."""
VEHICLE_IDS = {v.sysid: v.id for v in SCENARIO.vehicles}
"""uav1, uav2, uav3 by sysid."""
SYSIDS = tuple(VEHICLE_IDS)
ALTITUDE_M = {v.sysid: v.altitude_m for v in SCENARIO.vehicles}
"""200, 210 and 220 m above home, held in LOITER."""
MAX_GROUND_SPEED_MPS = 30.0
"""Above the vehicles' 25 m/s cruise in still air: how far one can move between two samples."""
CLIENT_SYSID = 254
"""A second ground station behind MAVProxy (MAVProxy itself is 255)."""


class SecondGroundStation(GroundStation):
    """The harness's pymavlink ground station as sysid 254, listening on MAVProxy's ``--out`` port."""

    def __init__(self) -> None:  # pylint: disable=super-init-not-called
        self.conn = open_connection(f"udpin:{LOCALHOST}:0", source_system=CLIENT_SYSID, source_component=190)
        self.port: int = self.conn.port.getsockname()[1]  # where MAVProxy's --out sends


@pytest.fixture
def flying(mavproxy: MavProxy) -> Iterator[Runner]:
    """The three vehicles flying at 10x towards ``mavproxy``, which has seen vehicle 1 in LOITER."""
    with running_vehicles(options(mavproxy.master_port, rate=RATE)) as runner:
        mavproxy.wait_for_vehicle(1, WAIT_S)
        mavproxy.wait_for_mode("LOITER", WAIT_S)
        yield runner


def modes(runner: Runner) -> dict[int, int]:
    """Every vehicle's current custom mode, by sysid."""
    return {sysid: runner.autopilots[VEHICLE_IDS[sysid]].mode for sysid in SYSIDS}


def truth_enu(runner: Runner, sysid: int) -> np.ndarray:
    """The vehicle's true ENU position (metres, up = height above home)."""
    return np.array(runner.scene.vehicles[VEHICLE_IDS[sysid]].state.position_enu_m, dtype=float)


def wait_simulated(runner: Runner, seconds: float, condition: Callable[[], bool], what: str) -> float:
    """Poll ``condition`` until it holds; fail after ``seconds`` of simulated time. Returns the simulated wait."""
    start = runner.scene.elapsed_s
    wall_deadline = time.monotonic() + 10 * seconds / RATE  # a backstop for a simulation that stalls
    while not condition():
        waited = runner.scene.elapsed_s - start
        if waited > seconds or time.monotonic() > wall_deadline:
            raise AssertionError(f"{what}: not within {waited:.1f} simulated s")
        time.sleep(0.02)
    return runner.scene.elapsed_s - start


def test_mavproxy_sees_every_vehicle_its_mode_gps_and_position(mavproxy: MavProxy, flying: Runner) -> None:
    runner, frame = flying, flying.scene.frame
    for sysid in SYSIDS:
        assert mavproxy.wait_for_vehicle(sysid, WAIT_S) == 1
    mavproxy.wait_for(r"online system 1\b", WAIT_S)
    assert mavproxy.mode == "LOITER"
    # The harness notes: fix_type 3 and a VFR_HUD with a non-zero (MSL) altitude print the lock.
    lock_m = int(mavproxy.wait_for(r"GPS lock at (\d+) meters", WAIT_S).group(1))
    assert abs(lock_m - (frame.height_m + ALTITUDE_M[1])) <= 2

    heartbeat = mavproxy.message("HEARTBEAT", WAIT_S)
    assert (heartbeat["type"], heartbeat["autopilot"], heartbeat["custom_mode"]) == (
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, LOITER)
    gps = mavproxy.message("GPS_RAW_INT", WAIT_S)
    assert gps["fix_type"] >= mavlink.GPS_FIX_TYPE_3D_FIX and gps["satellites_visible"] > 0

    position = mavproxy.message("GLOBAL_POSITION_INT", WAIT_S)
    now_s, truth = runner.scene.elapsed_s, truth_enu(runner, 1)
    # status shows the target's message: vehicle 1 (200 m), not vehicle 2 or 3 (210, 220 m).
    assert abs(position["relative_alt"] / 1000.0 - ALTITUDE_M[1]) < 2.0
    assert abs(position["alt"] / 1000.0 - (frame.height_m + ALTITUDE_M[1])) < 2.0
    reported = frame.to_enu(position["lat"] * 1e-7, position["lon"] * 1e-7, frame.height_m)
    age_s = now_s - position["time_boot_ms"] / 1000.0  # telemetry is stamped with simulated time
    assert 0.0 <= age_s < 5.0, f"MAVProxy's GLOBAL_POSITION_INT is {age_s:.2f} simulated s old"
    error_m = math.hypot(reported[0] - truth[0], reported[1] - truth[1])
    assert error_m <= MAX_GROUND_SPEED_MPS * age_s + 10.0, f"{error_m:.1f} m from the truth, {age_s:.2f} s old"


def test_mode_guided_switches_only_the_target_vehicle(mavproxy: MavProxy, flying: Runner) -> None:
    mavproxy.wait_for(r"online system 1\b", WAIT_S)
    assert modes(flying) == {1: LOITER, 2: LOITER, 3: LOITER}

    mavproxy.command("mode GUIDED", r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", WAIT_S)
    mavproxy.wait_for_mode("GUIDED", WAIT_S)
    assert modes(flying) == {1: GUIDED, 2: LOITER, 3: LOITER}
    assert mavproxy.message("HEARTBEAT", WAIT_S)["custom_mode"] == GUIDED


def test_guided_lat_lon_alt_flies_vehicle_one_to_the_point(mavproxy: MavProxy, flying: Runner) -> None:
    runner, frame = flying, flying.scene.frame
    autopilot = runner.autopilots["uav1"]
    goal = truth_enu(runner, 1) + np.array([1000.0, 0.0, 0.0])  # 1 km east, inside the 3 km city
    altitude_m = 250.0
    lat, lon, _ = frame.to_geodetic(goal)

    mavproxy.command(f"guided {lat:.7f} {lon:.7f} {altitude_m:g}", r"Got COMMAND_ACK: DO_REPOSITION: ACCEPTED",
                     WAIT_S)
    assert modes(runner) == {1: GUIDED, 2: LOITER, 3: LOITER}  # the change-mode flag of DO_REPOSITION
    mavproxy.wait_for_mode("GUIDED", WAIT_S)
    target = autopilot.guided_target_enu_m
    assert target is not None
    assert math.hypot(target[0] - goal[0], target[1] - goal[1]) < 2.0
    assert target[2] == altitude_m

    def distance_m() -> float:
        here = truth_enu(runner, 1)
        return math.hypot(here[0] - goal[0], here[1] - goal[1])

    radius_m = autopilot.guidance.radius_m
    assert distance_m() > radius_m + 500.0
    # About 850 m to the loiter circle at 25 m/s and 50 m of climb at 5 m/s: 35 s of flight.
    wait_simulated(runner, 60.0, lambda: distance_m() < radius_m + 25.0
                   and abs(truth_enu(runner, 1)[2] - altitude_m) < 5.0, "vehicle 1 at the point and 250 m")
    assert autopilot.mode == GUIDED
    position = mavproxy.message("GLOBAL_POSITION_INT", WAIT_S)
    assert position["relative_alt"] / 1000.0 > altitude_m - 10.0  # MAVProxy sees the climb too


def test_mavproxy_routes_a_second_ground_station_to_the_vehicles(tmp_path: Path) -> None:
    client = SecondGroundStation()
    try:
        with MavProxy(outs=[f"udpout:{LOCALHOST}:{client.port}"], workdir=tmp_path / "mavproxy") as proxy, \
                running_vehicles(options(proxy.master_port, rate=RATE)) as runner:
            for sysid in SYSIDS:
                beat = client.wait("HEARTBEAT", sysid, WAIT_S)
                assert (beat.type, beat.custom_mode) == (mavlink.MAV_TYPE_FIXED_WING, LOITER)

            client.command_long(2, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            ack = client.wait("COMMAND_ACK", 2, WAIT_S, lambda m: m.command == mavlink.MAV_CMD_DO_SET_MODE)
            assert (ack.result, ack.target_system) == (mavlink.MAV_RESULT_ACCEPTED, CLIENT_SYSID)
            assert modes(runner) == {1: LOITER, 2: GUIDED, 3: LOITER}
            client.wait("HEARTBEAT", 2, WAIT_S, lambda m: m.custom_mode == GUIDED)
            assert proxy.mode == "LOITER"  # MAVProxy's own target, vehicle 1, is unchanged
    finally:
        client.close()


def test_vehicle_two_then_mode_circle_switches_only_vehicle_two(mavproxy: MavProxy, flying: Runner) -> None:
    mavproxy.wait_for_vehicle(2, WAIT_S)
    mavproxy.command("vehicle 2", r"Set vehicle 2\b", WAIT_S)
    mavproxy.command("mode CIRCLE", r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", WAIT_S)
    mavproxy.wait_for_mode("CIRCLE", WAIT_S)
    assert modes(flying) == {1: LOITER, 2: CIRCLE, 3: LOITER}
    position = mavproxy.message("GLOBAL_POSITION_INT", WAIT_S)  # status now shows vehicle 2
    assert abs(position["relative_alt"] / 1000.0 - ALTITUDE_M[2]) < 2.0
