"""Autopilot personalities: ArduPlane ignores carrots and turns by its guided heading PID, PX4 needs its setpoint
stream, and each streams telemetry at its own default rates until asked (sim_vehicles.personalities)."""

from __future__ import annotations

import math
from importlib import resources

import pytest

from gcs.adapters.mavlink_wire import mavlink
from gcs.config import ScenarioError
from gcs.config.simulation import AirframeConfig
from gcs.scenarios import load_scenario
from sim_vehicles.arduplane import TURN_EFFICIENCY
from sim_vehicles.guided_heading import bank_limit_cd
from sim_vehicles.truth.fixed_wing import GRAVITY_MPS2
from tests.autopilot_harness import ALTITUDE, FRAME, SPEED, Flight

GUIDED_ARDUPLANE = 15
ACCEPTED, FAILED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED, mavlink.MAV_RESULT_DENIED
UNSUPPORTED, REJECTED = mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED
RELATIVE_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


def _carrot(flight: Flight, east_m: float, north_m: float, altitude_m: float, mask: int = 0x09F8):
    lat, lon, _ = FRAME.to_geodetic([east_m, north_m, altitude_m])
    return flight.gcs.set_position_target_global_int_encode(0, 1, 1, RELATIVE_INT, mask, round(lat * 1e7),
                                                            round(lon * 1e7), altitude_m, 0, 0, 0, 0, 0, 0, 0, 0)


def _guided(name: str, **kw) -> Flight:
    flight = Flight(name, **kw)
    assert flight.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, GUIDED_ARDUPLANE) == ACCEPTED
    return flight


# ------------------------------------------------------------------ scenario setting


def test_scenario_names_the_personality_per_vehicle_and_rejects_unknown_names(tmp_path) -> None:
    scenario = load_scenario("wang2012_urban")
    assert {scenario.autopilot_for(v) for v in scenario.vehicles} == {"arduplane"}  # the default scenario's
    downtown = load_scenario("downtown_dense")
    assert {downtown.autopilot_for(v) for v in downtown.vehicles} == {"ideal"}  # the configuration's default
    base = (resources.files("gcs.scenarios") / "wang2012_urban.toml").read_text()
    first_vehicle = base.index("[[vehicles]]") + len("[[vehicles]]")
    overridden = tmp_path / "px4.toml"
    overridden.write_text(base[:first_vehicle] + '\nautopilot = "px4"' + base[first_vehicle:])
    scenario = load_scenario(overridden)
    assert [scenario.autopilot_for(v) for v in scenario.vehicles] == ["px4", "arduplane", "arduplane"]
    unknown = tmp_path / "unknown.toml"
    unknown.write_text(base.replace('autopilot = "arduplane"', 'autopilot = "ardupilot"'))
    with pytest.raises(ScenarioError) as error:
        load_scenario(unknown)
    message = str(error.value)
    assert "$.simulation.autopilot: unknown autopilot 'ardupilot'; expected one of: ideal, arduplane, px4" in message
    assert "\n" not in message


# ------------------------------------------------------------------ ArduPlane


def test_arduplane_ignores_the_carrot_horizontally_and_takes_its_altitude() -> None:
    with_carrots, without = _guided("arduplane"), _guided("arduplane")
    # the carrot lies 90 degrees to the left, 600 m away, at 230 m
    with_carrots.fly(30.0, every=lambda f: f.send(_carrot(f, f.state.position_enu_m[0], 1600.0, 230.0)))
    without.fly(30.0)
    assert with_carrots.state.position_enu_m[:2] == pytest.approx(without.state.position_enu_m[:2], abs=1e-9)
    assert with_carrots.state.position_enu_m[2] == pytest.approx(230.0, abs=0.5)
    assert without.state.position_enu_m[2] == pytest.approx(ALTITUDE, abs=1e-6)
    assert with_carrots.ap.counters["position_target_horizontal_ignored"] == 600


def _heading_step(name: str, step_deg: float, accel_mps2: float, seconds: float) -> tuple[Flight, list]:
    flight = _guided(name)
    yaw_deg = (90.0 - step_deg) % 360.0  # start heading east (NED yaw 90); a positive step turns left
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, 1, yaw_deg, accel_mps2,
                          frame=RELATIVE_INT) == ACCEPTED
    return flight, flight.fly(seconds)


def test_arduplane_small_heading_step_follows_the_closed_loop_of_its_pid_and_bank_lag() -> None:
    """Below the bank limit: phi_c = kp e, phi lags with tau_phi, psi_dot = eta g phi / V (the turn efficiency),
    so the error obeys tau_phi e'' + e' + K e = 0, K = eta g kp / V;
    e(t) = e0 (s2 exp(s1 t) - s1 exp(s2 t)) / (s2 - s1)."""
    step = math.radians(4.0)
    flight, states = _heading_step("arduplane", 4.0, 5.0, 15.0)
    kp = math.radians(5000.0 / 100.0)  # GUIDED_P 5000 cdeg/rad (ArduPlane/Parameters.h)
    gain, tau = TURN_EFFICIENCY * GRAVITY_MPS2 * kp / SPEED, AirframeConfig().roll_time_constant_s
    root = math.sqrt(1.0 - 4.0 * tau * gain)
    s1, s2 = (-1.0 + root) / (2.0 * tau), (-1.0 - root) / (2.0 * tau)
    for t in (1.0, 2.0, 3.0, 5.0, 8.0):
        expected = step * (s2 * math.exp(s1 * t) - s1 * math.exp(s2 * t)) / (s2 - s1)
        error = step - states[round(t / 0.05) - 1].heading_rad
        assert error == pytest.approx(expected, abs=0.04 * step), t
    assert abs(flight.ap.bank_demand_cd) < bank_limit_cd(5.0, flight.ap.params["ROLL_LIMIT_DEG"])


def test_arduplane_large_heading_step_turns_at_the_bank_limit_of_param3() -> None:
    """A 120 degree step saturates the PID at atan(a / g): the turn rate is eta g tan(atan(a / g)) / V = eta a / V."""
    accel = 4.0
    flight, states = _heading_step("arduplane", 120.0, accel, 30.0)
    rate = TURN_EFFICIENCY * accel / SPEED
    middle = [s.turn_rate_rad_s for s in states if 0.5 < s.heading_rad < 1.2]
    assert min(middle) == pytest.approx(rate, rel=0.01) and max(middle) == pytest.approx(rate, rel=0.01)
    assert states[-1].heading_rad == pytest.approx(math.radians(120.0), abs=math.radians(0.5))


def test_arduplane_guided_altitude_holds_until_the_mode_changes() -> None:
    flight = _guided("arduplane")
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, 0, 0, 0, 0, 0, 0, 260.0,
                          frame=RELATIVE_INT) == ACCEPTED
    lat, lon, _ = FRAME.to_geodetic([3000.0, 1000.0, 0.0])
    point = (0, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, lat * 1e7, lon * 1e7, 180.0)
    assert flight.command(mavlink.MAV_CMD_DO_REPOSITION, *point, frame=RELATIVE_INT) == ACCEPTED
    assert flight.ap.guidance.altitude_m == 260.0  # the reposition's 180 m is overridden
    assert flight.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, 12) == ACCEPTED  # LOITER
    assert flight.command(mavlink.MAV_CMD_DO_REPOSITION, *point, frame=RELATIVE_INT) == ACCEPTED  # back to GUIDED
    assert flight.ap.guidance.altitude_m == 180.0
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, 0, 0, 0, 0, 0, 0, 0.0,
                          frame=RELATIVE_INT) == DENIED


def test_arduplane_answers_as_the_real_one() -> None:
    flight = Flight("arduplane")  # LOITER
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, 1, 90.0, 5.0, frame=RELATIVE_INT) == FAILED
    assert flight.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 20.0, -1) == FAILED
    assert flight.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0) == FAILED
    assert flight.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, GUIDED_ARDUPLANE) == ACCEPTED
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, 1, 360.0, 5.0, frame=RELATIVE_INT) == DENIED
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_SPEED, 1, 20.0, frame=RELATIVE_INT) == DENIED
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_SPEED, 0, 90.0, frame=RELATIVE_INT) == FAILED
    assert flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_SPEED, 0, 20.0, frame=RELATIVE_INT) == ACCEPTED
    assert flight.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, 99) == FAILED
    heartbeat = flight._wire(flight.ap.heartbeat(), flight.vehicle_side)
    assert (heartbeat.autopilot, heartbeat.custom_mode) == (mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, GUIDED_ARDUPLANE)


def test_arduplane_streams_at_1_hz_until_asked() -> None:
    flight = Flight("arduplane")
    counts = flight.streamed(10.0)
    assert counts["GLOBAL_POSITION_INT"] == 10 and counts["ATTITUDE"] == 10
    flight.send(flight.gcs.request_data_stream_encode(1, 1, mavlink.MAV_DATA_STREAM_POSITION, 5, 1))
    assert flight.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 100_000) == ACCEPTED
    counts = flight.streamed(10.0)
    assert counts["GLOBAL_POSITION_INT"] == 50 and counts["ATTITUDE"] == 100 and counts["VFR_HUD"] == 10
    assert flight.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -1) == ACCEPTED
    assert flight.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 0) \
        == ACCEPTED
    assert flight.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_SCALED_IMU, 100_000) == FAILED
    counts = flight.streamed(10.0)
    assert "ATTITUDE" not in counts and counts["GLOBAL_POSITION_INT"] == 10


def test_ideal_keeps_the_scenario_rate_and_obeys_carrots() -> None:
    flight = _guided("ideal")
    assert flight.streamed(10.0)["GLOBAL_POSITION_INT"] == 40
    flight.fly(60.0, every=lambda f: f.send(_carrot(f, f.state.position_enu_m[0], 2000.0, ALTITUDE)))
    assert flight.state.position_enu_m[1] > 1800.0  # it turned north toward the carrots


# ------------------------------------------------------------------ PX4


def _offboard(flight: Flight) -> int:
    return flight.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, 6, 0)


def test_px4_refuses_offboard_without_a_setpoint_stream_and_drops_out_after_com_of_loss_t() -> None:
    flight = Flight("px4")
    hold = flight.ap.mode
    assert _offboard(flight) == REJECTED and flight.ap.mode == hold
    flight.send(_carrot(flight, 1000.0, 3000.0, ALTITUDE))
    flight.fly(1.5)  # older than COM_OF_LOSS_T = 1 s
    assert _offboard(flight) == REJECTED
    flight.send(_carrot(flight, 1000.0, 3000.0, ALTITUDE))
    assert _offboard(flight) == ACCEPTED and flight.ap.mode == 6 << 16
    heartbeat = flight._wire(flight.ap.heartbeat(), flight.vehicle_side)
    assert (heartbeat.autopilot, heartbeat.custom_mode) == (mavlink.MAV_AUTOPILOT_PX4, 393216)
    flight.fly(0.95)
    assert flight.ap.mode_name == "OFFBOARD"
    flight.fly(0.2)
    assert flight.ap.mode_name == "POSCTL"  # COM_OBL_RC_ACT 0
    assert flight.ap.counters["offboard_lost"] == 1


def test_px4_follows_the_carrot_stream_in_offboard() -> None:
    flight = Flight("px4")
    goal = (1000.0, 2500.0)  # 1500 m north; the vehicle heads east

    def stream(f: Flight) -> None:
        if round(f.t / 0.05) % 5 == 0:  # 4 Hz
            f.send(_carrot(f, *goal, 220.0))

    stream(flight)
    assert _offboard(flight) == ACCEPTED
    states = flight.fly(60.0, every=stream)
    distances = [math.dist(s.position_enu_m[:2], goal) for s in states]
    assert distances[-1] < 200.0 < 1500.0  # arrived and circles within NAV_LOITER_RAD + overshoot
    assert states[-1].position_enu_m[2] == pytest.approx(220.0, abs=0.5)
    assert flight.ap.mode_name == "OFFBOARD"


def test_px4_answers_guided_change_commands_as_unsupported_and_ignores_request_data_stream() -> None:
    flight = Flight("px4")
    for command in (mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, mavlink.MAV_CMD_GUIDED_CHANGE_SPEED,
                    mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE):
        assert flight.command(command, 1, 90.0, 5.0, frame=RELATIVE_INT) == UNSUPPORTED
    assert flight.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0) == REJECTED
    flight.send(flight.gcs.request_data_stream_encode(1, 1, mavlink.MAV_DATA_STREAM_ALL, 1, 1))
    counts = flight.streamed(10.0)
    assert counts["GLOBAL_POSITION_INT"] == 50 and counts["ATTITUDE"] == 150  # PX4's 5 Hz and 15 Hz
    assert flight.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                          500_000) == ACCEPTED
    assert flight.streamed(10.0)["GLOBAL_POSITION_INT"] == 20
