"""The course loops the daemon steers with (:data:`gcs.core.steering.COURSE_LOOPS`) are the ones ``gcs-bench
autopilots --identify`` finds from the simulated autopilots' step responses, and those match the closed forms
(ArduPlane's ``K = g k_p / V`` with GUIDED_P's default, the ideal airframe's heading gain and roll lag)."""

from __future__ import annotations

import math

import pytest

from benchmarks.autopilots import identify
from gcs.config.simulation import AirframeConfig
from gcs.core.steering import COURSE_LOOPS
from sim_vehicles.guided_heading import GRAVITY_MSS, GUIDED_P_DEFAULT

SPEED = 25.0


@pytest.mark.parametrize("personality", ["ideal", "arduplane"])
def test_course_loops_steered_with_are_the_ones_the_step_responses_identify(personality: str) -> None:
    found, used = identify(personality), COURSE_LOOPS[personality]
    assert found.gain_per_s == pytest.approx(used.gain_per_s, rel=0.02)
    assert found.lag_s == pytest.approx(used.lag_s, rel=0.02)
    assert found.max_turn_rate_rad_s == pytest.approx(used.max_turn_rate_rad_s, rel=0.01)


def test_identified_gains_match_the_closed_form_loops() -> None:
    airframe = AirframeConfig()
    kp_rad = GUIDED_P_DEFAULT / 100.0 * math.pi / 180.0  # centidegrees of bank per radian -> radians per radian
    assert identify("arduplane").gain_per_s == pytest.approx(GRAVITY_MSS * kp_rad / SPEED, rel=0.03)
    assert identify("ideal").gain_per_s == pytest.approx(airframe.heading_gain_per_s, rel=0.03)
    assert identify("arduplane").lag_s == pytest.approx(airframe.roll_time_constant_s, rel=0.1)

