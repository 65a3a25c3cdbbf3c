"""Steering along a planned path through an autopilot's course loop (gcs/core/steering.py).

Independent figures: kinematics' own rollout for the path, and flights of the simulated autopilots
(tests/autopilot_harness.py) steered with and without the lead, and the course loops' closed forms
(ArduPlane's ``K = g k_p / V`` with GUIDED_P's default, the ideal airframe's heading gain).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.adapters.mavlink_wire import mavlink, ned_yaw_from_enu_heading
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout
from gcs.core.steering import COURSE_LOOPS, STEERING_HEADROOM, PlannedPath, follow
from sim_vehicles.arduplane import TURN_EFFICIENCY
from sim_vehicles.guided_heading import GRAVITY_MSS, GUIDED_P_DEFAULT
from tests.autopilot_harness import ALTITUDE, SPEED, Flight

STEER_PERIOD_S = 0.25


def start(x: float = 1000.0, y: float = 1000.0, heading: float = 0.0) -> VehicleState:
    return VehicleState(np.array([[x, y]]), np.array([heading]), np.array([SPEED]), np.array([ALTITUDE]))


# ------------------------------------------------------------------ course loops


def test_the_course_loops_steered_with_are_their_closed_forms() -> None:
    airframe = AirframeConfig()
    kp_rad = GUIDED_P_DEFAULT / 100.0 * math.pi / 180.0  # centidegrees of bank per radian -> radians per radian
    arduplane, ideal = COURSE_LOOPS["arduplane"], COURSE_LOOPS["ideal"]
    assert arduplane.airspeed_mps == ideal.airspeed_mps == SPEED
    # ArduPlane's (identified on SITL): the GUIDED_ PID's bank through a turn of eta of the coordinated rate
    assert arduplane.gain_per_s == pytest.approx(TURN_EFFICIENCY * GRAVITY_MSS * kp_rad / SPEED, rel=0.05)
    assert ideal.gain_per_s == pytest.approx(airframe.heading_gain_per_s, rel=0.03)
    assert ideal.lag_s == pytest.approx(airframe.roll_time_constant_s, rel=0.1)


def test_a_vehicle_is_planned_below_the_turn_rate_its_autopilot_reaches() -> None:
    arduplane, ideal = COURSE_LOOPS["arduplane"], COURSE_LOOPS["ideal"]
    assert arduplane.flyable_turn_rate(0.2) == pytest.approx(STEERING_HEADROOM * arduplane.max_turn_rate_rad_s)
    assert arduplane.flyable_turn_rate(0.1) == pytest.approx(arduplane.flyable_turn_rate(0.2) / 2)  # accel sent halves
    assert ideal.flyable_turn_rate(0.2) == pytest.approx(STEERING_HEADROOM * 0.2, rel=1e-3)  # it reaches its limit


def test_a_bank_to_turn_gain_scales_inversely_with_airspeed() -> None:
    arduplane, ideal = COURSE_LOOPS["arduplane"], COURSE_LOOPS["ideal"]
    assert arduplane.gain_at(50.0) == pytest.approx(arduplane.gain_per_s / 2.0)
    assert ideal.gain_at(50.0) == ideal.gain_per_s


# ------------------------------------------------------------------ the path


def test_planned_path_ends_where_the_plan_does_and_carries_its_turn_rates() -> None:
    rates = np.array([0.1, -0.2, 0.0, 0.15])
    path = PlannedPath.from_plan(start(heading=0.3), rates, 1.0, 0.2)
    xy, heading = rollout(start(heading=0.3), rates[None, :], 1.0, 0.2)
    assert path.points[-1] == pytest.approx(xy[0, -1], abs=1e-6)
    assert path.courses[-1] == pytest.approx(heading[0, -1], abs=1e-9)
    assert path.points[0] == pytest.approx([1000.0, 1000.0])
    assert path.turn_rates[15] == pytest.approx(-0.2) and len(path.points) == 41


def test_cross_track_is_positive_to_the_left_of_the_course() -> None:
    path = PlannedPath.from_plan(start(heading=0.0), np.zeros(5), 1.0, 0.2)  # east along y = 1000
    assert path.cross_track_m(10, [1025.0, 1010.0]) == pytest.approx(10.0)
    assert path.cross_track_m(10, [1025.0, 990.0]) == pytest.approx(-10.0)


# ------------------------------------------------------------------ the law


def test_on_a_straight_path_on_course_nothing_is_asked() -> None:
    path = PlannedPath.from_plan(start(), np.zeros(5), 1.0, 0.2)
    result = follow(path, np.array([1050.0, 1000.0]), 0.0, SPEED, COURSE_LOOPS["arduplane"], period_s=STEER_PERIOD_S)
    assert result.turn_rate_rad_s == 0.0 and result.command_course_rad == 0.0


def test_on_an_arc_the_lead_is_the_error_that_turns_the_loop_at_the_planned_rate() -> None:
    rate, loop = 0.1, COURSE_LOOPS["arduplane"]
    path = PlannedPath.from_plan(start(), np.full(5, rate), 1.0, 0.2)
    on = 12  # a point of the arc, flying its course
    result = follow(path, path.points[on], float(path.courses[on]), SPEED, loop, period_s=STEER_PERIOD_S)
    assert result.turn_rate_rad_s == pytest.approx(rate, abs=1e-9)
    lead = rate / loop.gain_per_s + rate * STEER_PERIOD_S / 2.0
    assert wrap_angle(result.command_course_rad - path.courses[on]) == pytest.approx(lead, abs=1e-9)


def test_left_of_the_path_turns_right_and_the_rate_is_bounded() -> None:
    path = PlannedPath.from_plan(start(), np.zeros(10), 1.0, 0.2)
    loop = COURSE_LOOPS["ideal"]
    near = follow(path, np.array([1100.0, 1020.0]), 0.0, SPEED, loop, period_s=STEER_PERIOD_S)
    far = follow(path, np.array([1100.0, 3000.0]), math.pi / 2, SPEED, loop, period_s=STEER_PERIOD_S)
    assert near.turn_rate_rad_s < 0.0 and near.cross_track_m == pytest.approx(20.0)
    assert far.turn_rate_rad_s == -loop.max_turn_rate_rad_s


def test_past_the_end_the_last_course_is_held() -> None:
    path = PlannedPath.from_plan(start(), np.full(3, 0.2), 1.0, 0.2)
    beyond = path.points[-1] + 200.0 * np.array([math.cos(path.courses[-1]), math.sin(path.courses[-1])])
    result = follow(path, beyond, float(path.courses[-1]), SPEED, COURSE_LOOPS["ideal"], period_s=STEER_PERIOD_S)
    assert result.turn_rate_rad_s == pytest.approx(0.0, abs=1e-9)


# ------------------------------------------------------------------ flown


def _fly_path(personality: str, lead: bool) -> float:
    """Median |course error| against an S-shaped plan (10 s left at 0.1 rad/s, 10 s right, 10 s left) flown
    by the personality steered at 4 Hz: with the lead, or commanding the path's own course (no lead)."""
    flight = Flight(personality, max_turn_rate_rad_s=0.2)
    flight.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15)
    rates = np.concatenate([np.full(10, 0.1), np.full(10, -0.1), np.full(10, 0.1)])
    here = VehicleState(flight.state.position_enu_m[None, :2], np.array([0.0]), np.array([SPEED]),
                        np.array([ALTITUDE]))
    path = PlannedPath.from_plan(here, rates, 1.0, 0.2)
    errors = []
    for _ in range(int(28 / STEER_PERIOD_S)):
        position, course = flight.state.position_enu_m[:2], flight.state.course_rad(flight.wind)
        result = follow(path, position, course, SPEED, COURSE_LOOPS[personality], period_s=STEER_PERIOD_S)
        target = result.command_course_rad if lead else float(path.courses[path.nearest(position)])
        course_ned = math.degrees(ned_yaw_from_enu_heading(target)) % 360.0
        flight.command(mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, 0, course_ned, 1.25 * SPEED * 0.2,
                       frame=mavlink.MAV_FRAME_GLOBAL)
        errors.append(abs(result.course_error_rad))
        flight.fly(STEER_PERIOD_S)
    return math.degrees(float(np.median(errors[12:])))  # after 3 s


def test_arduplane_flies_the_plan_within_two_degrees_with_the_lead_and_not_without() -> None:
    with_lead, without = _fly_path("arduplane", lead=True), _fly_path("arduplane", lead=False)
    assert with_lead < 2.0
    assert without > 2.0 * with_lead


def test_the_ideal_airframe_flies_the_plan_within_two_degrees_with_the_lead() -> None:
    assert _fly_path("ideal", lead=True) < 2.0
