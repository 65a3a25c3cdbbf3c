"""The course loops the daemon steers with (:data:`gcs.core.steering.COURSE_LOOPS`) against the simulated autopilots'
step responses as ``gcs-bench autopilots --identify`` finds them: the ideal airframe's loop is its own, and the
``arduplane`` personality, fitted to the real ArduPlane (SITL), gives the real loop's gain and largest turn rate
within 10%. Both match their closed forms (ArduPlane's ``K = eta g k_p / V`` with GUIDED_P's default and the
fitted turn efficiency, the ideal airframe's heading gain and roll lag)."""

from __future__ import annotations

import math

import pytest

from benchmarks.autopilots import identify
from gcs.adapters.mavlink_commands import LATERAL_ACCEL_MARGIN
from gcs.config.simulation import AirframeConfig
from gcs.core.steering import COURSE_LOOPS, IDENTIFIED_AT_TURN_RATE_RAD_S
from sim_vehicles.arduplane import TURN_EFFICIENCY
from sim_vehicles.guided_heading import GRAVITY_MSS, GUIDED_P_DEFAULT

SPEED = 25.0


def test_the_ideal_loop_steered_with_is_the_one_its_step_responses_identify() -> None:
    found, used = identify("ideal"), COURSE_LOOPS["ideal"]
    assert found.gain_per_s == pytest.approx(used.gain_per_s, rel=0.02)
    assert found.lag_s == pytest.approx(used.lag_s, rel=0.02)
    assert found.max_turn_rate_rad_s == pytest.approx(used.max_turn_rate_rad_s, rel=0.01)


def test_the_arduplane_personality_turns_as_the_real_loop_steered_with() -> None:
    """The personality's roll lag is the scenario airframe's (0.5 s), not SITL's: only gain and rate are fitted."""
    found, real = identify("arduplane"), COURSE_LOOPS["arduplane"]
    assert found.gain_per_s == pytest.approx(real.gain_per_s, rel=0.1)
    assert found.max_turn_rate_rad_s == pytest.approx(real.max_turn_rate_rad_s, rel=0.1)


def test_identified_gains_and_rates_match_the_closed_form_loops() -> None:
    airframe = AirframeConfig()
    kp_rad = GUIDED_P_DEFAULT / 100.0 * math.pi / 180.0  # centidegrees of bank per radian -> radians per radian
    arduplane = identify("arduplane")
    assert arduplane.gain_per_s == pytest.approx(TURN_EFFICIENCY * GRAVITY_MSS * kp_rad / SPEED, rel=0.05)
    # the bank limit atan(a / g) of the acceleration a = margin V omega sent: omega = eta a / V
    assert arduplane.max_turn_rate_rad_s == pytest.approx(
        TURN_EFFICIENCY * LATERAL_ACCEL_MARGIN * IDENTIFIED_AT_TURN_RATE_RAD_S, rel=0.03)
    assert identify("ideal").gain_per_s == pytest.approx(airframe.heading_gain_per_s, rel=0.03)
    assert arduplane.lag_s == pytest.approx(airframe.roll_time_constant_s, rel=0.1)
