"""The simulated fixed-wing: limits, first-order responses, guidance laws, wind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.config.simulation import AirframeConfig
from sim_vehicles.truth.fixed_wing import GRAVITY_MPS2, Airframe, AirframeState, Guidance

DT = 0.05
CONFIG = AirframeConfig()


def _state(heading: float = 0.0, airspeed: float = 25.0, altitude: float = 200.0) -> AirframeState:
    return AirframeState(np.array([0.0, 0.0, altitude]), heading_rad=heading, roll_rad=0.0, airspeed_mps=airspeed)


def _fly(airframe: Airframe, state: AirframeState, guidance: Guidance, seconds: float) -> list[AirframeState]:
    states = [state]
    for _ in range(round(seconds / DT)):
        states.append(airframe.step(states[-1], guidance, DT))
    return states


def _course(direction: float, **kw) -> Guidance:
    return Guidance(kind="course", altitude_m=kw.pop("altitude_m", 200.0), airspeed_mps=kw.pop("airspeed_mps", 25.0),
                    direction_rad=direction, **kw)


def test_course_command_converges_within_turn_rate_and_bank_limits() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    states = _fly(airframe, _state(heading=0.0), _course(math.pi / 2), 40.0)
    assert abs(states[-1].heading_rad - math.pi / 2) < 1e-3
    assert max(abs(s.turn_rate_rad_s) for s in states) <= 0.2 + 1e-12
    assert max(abs(s.roll_rad) for s in states) <= CONFIG.max_bank_rad
    # a 90 degree turn at 0.2 rad/s takes at least pi/2/0.2 = 7.85 s
    first = next(i for i, s in enumerate(states) if abs(s.heading_rad - math.pi / 2) < 0.05)
    assert first * DT >= (math.pi / 2 - 0.05) / 0.2


def test_bank_limit_caps_turn_rate_below_the_vehicle_limit() -> None:
    config = AirframeConfig(max_bank_rad=0.2)
    airframe = Airframe(config, max_turn_rate_rad_s=1.0)
    expected = GRAVITY_MPS2 * math.tan(0.2) / 25.0
    states = _fly(airframe, _state(), _course(math.pi), 8.0)
    assert max(abs(s.turn_rate_rad_s) for s in states) == pytest.approx(expected, rel=1e-3)


def test_bank_follows_a_saturated_command_as_a_first_order_lag() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    roll_command = math.atan(0.2 * 25.0 / GRAVITY_MPS2)  # turn-rate limit binds for a 180 degree error
    states = _fly(airframe, _state(), _course(math.pi - 0.01), 1.0)
    for k in (2, 10, 20):
        t = k * DT
        assert states[k].roll_rad == pytest.approx(roll_command * (1 - math.exp(-t / CONFIG.roll_time_constant_s)),
                                                   rel=1e-9)


def test_airspeed_and_altitude_holds() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    states = _fly(airframe, _state(), _course(0.0, airspeed_mps=30.0, altitude_m=260.0), 60.0)
    tau = CONFIG.airspeed_time_constant_s
    assert states[round(tau / DT)].airspeed_mps == pytest.approx(30.0 - 5.0 * math.exp(-1.0), rel=1e-9)
    climbs = [s.climb_rate_mps for s in states]
    assert max(climbs) == pytest.approx(CONFIG.max_climb_rate_mps)
    assert states[-1].position_enu_m[2] == pytest.approx(260.0, abs=0.01)
    assert max(s.position_enu_m[2] for s in states) <= 260.0 + 1e-9


def test_straight_flight_covers_airspeed_times_time() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    states = _fly(airframe, _state(heading=0.3), _course(0.3), 10.0)
    assert states[-1].position_enu_m[:2] == pytest.approx(250.0 * np.array([math.cos(0.3), math.sin(0.3)]))
    assert states[-1].distance_m == pytest.approx(250.0)


def test_course_command_in_wind_crabs_and_tracks_the_ground_course() -> None:
    wind = (0.0, 8.0)  # from the south
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2, wind_enu_mps=wind)
    states = _fly(airframe, _state(), _course(0.0), 60.0)
    final = states[-1]
    assert final.course_rad(wind) == pytest.approx(0.0, abs=1e-3)
    assert final.heading_rad == pytest.approx(-math.asin(8.0 / 25.0), abs=1e-3)  # crab into the wind
    heading_guidance = Guidance(kind="heading", altitude_m=200.0, airspeed_mps=25.0, direction_rad=0.0)
    held = _fly(airframe, final, heading_guidance, 60.0)[-1]
    assert held.heading_rad == pytest.approx(0.0, abs=1e-3)
    assert held.course_rad(wind) == pytest.approx(math.atan2(8.0, 25.0), abs=1e-3)


@pytest.mark.parametrize("clockwise", [True, False])
def test_loiter_settles_on_the_circle_in_the_commanded_direction(clockwise: bool) -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    guidance = Guidance(kind="loiter", altitude_m=200.0, airspeed_mps=25.0, point_enu_m=(600.0, -300.0),
                        radius_m=200.0, clockwise=clockwise)
    states = _fly(airframe, _state(), guidance, 400.0)
    tail = states[-400:]
    radii = [math.hypot(s.position_enu_m[0] - 600.0, s.position_enu_m[1] + 300.0) for s in tail]
    assert max(abs(r - 200.0) for r in radii) < 5.0
    rx, ry = tail[-1].position_enu_m[0] - 600.0, tail[-1].position_enu_m[1] + 300.0
    v = tail[-1].ground_velocity((0.0, 0.0))
    spin = rx * v[1] - ry * v[0]  # > 0 counter-clockwise
    assert (spin < 0) == clockwise


def test_goto_arrives_then_circles_the_point() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    guidance = Guidance(kind="goto", altitude_m=200.0, airspeed_mps=25.0, point_enu_m=(-1500.0, 800.0),
                        radius_m=150.0)
    states = _fly(airframe, _state(), guidance, 300.0)
    distances = [math.hypot(s.position_enu_m[0] + 1500.0, s.position_enu_m[1] - 800.0) for s in states]
    arrival = next(i for i, d in enumerate(distances) if d <= 150.0)
    assert arrival * DT < 1700.0 / 25.0 + 20.0  # roughly straight there
    assert max(distances[-1200:]) < 155.0  # and then circles it


def test_turn_rate_cap_of_a_command_is_honoured() -> None:
    airframe = Airframe(CONFIG, max_turn_rate_rad_s=0.2)
    states = _fly(airframe, _state(), _course(math.pi / 2, max_turn_rate_rad_s=0.05), 10.0)
    assert max(abs(s.turn_rate_rad_s) for s in states) <= 0.05 + 1e-12
