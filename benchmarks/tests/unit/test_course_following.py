"""The course-following figures (:mod:`benchmarks.course_following`) on flights whose answer is known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.course_following import SteeringSample, course_following, saturated_turn_rates

LIMIT = 0.2


def turning(share: float, seconds: float = 20.0, planned: float = LIMIT, error_deg: float = 2.0) -> list[SteeringSample]:
    """A vehicle asked for ``planned`` that turns at ``share`` of the limit, sampled at 4 Hz."""
    times = np.arange(0.0, seconds, 0.25)
    return [SteeringSample(float(t), math.remainder(share * LIMIT * t, 2 * math.pi), math.radians(error_deg), planned)
            for t in times]


def test_a_vehicle_turning_at_a_share_of_the_limit_achieves_that_share() -> None:
    figures = course_following([turning(0.8), turning(0.6, planned=-LIMIT)], LIMIT)
    # the second turns left while asked to turn right: its rate counts against the planned direction
    rates = sorted(saturated_turn_rates(turning(0.8), LIMIT))
    assert rates[0] == pytest.approx(0.8 * LIMIT) and rates[-1] == pytest.approx(0.8 * LIMIT)
    assert figures["turn_rate_planned_deg_s"] == pytest.approx(math.degrees(LIMIT))
    assert figures["course_error_deg_median"] == pytest.approx(2.0)
    assert 0.0 < figures["saturated_share"] <= 1.0


def test_instants_not_asking_for_the_limit_are_left_out() -> None:
    assert saturated_turn_rates(turning(0.5, planned=0.9 * LIMIT), LIMIT) == []
    figures = course_following([turning(0.5, planned=0.5 * LIMIT)], LIMIT)
    assert math.isnan(figures["turn_rate_ratio"]) and figures["saturated_share"] == 0.0


def test_a_turn_reversed_within_the_window_is_not_counted() -> None:
    samples = turning(1.0, seconds=4.0) + [SteeringSample(4.0 + 0.25 * k, 0.0, 0.0, -LIMIT) for k in range(2)]
    rates = saturated_turn_rates(samples, LIMIT)
    assert len(rates) == len([s for s in samples[:16] if s.time_s >= 1.0])  # only the left turn's held instants
