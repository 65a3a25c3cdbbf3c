"""The lost-track figures (benchmarks/lost_track.py) on runs worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from benchmarks.lost_track import NEES_BAND, error_figures, longest_unseen, nees_inside


def test_errors_over_the_thresholds_are_counted_by_step_and_by_run() -> None:
    runs = [np.array([np.nan, 10.0, 60.0, 120.0]), np.array([5.0, 51.0, 49.0]), np.array([1.0, 2.0])]
    figures = error_figures(runs)
    assert figures["steps"] == 8  # the NaN (no track yet) is not a step with a track
    assert figures["steps_over_50"] == 3 and figures["steps_over_100"] == 1
    assert figures["runs_over_50"] == 2 and figures["runs_over_100"] == 1
    assert figures["max_m"] == 120.0
    pooled = np.array([10.0, 60.0, 120.0, 5.0, 51.0, 49.0, 1.0, 2.0])
    assert figures["p95_m"] == pytest.approx(np.sort(pooled)[6] + 0.65 * (120.0 - 60.0))  # linear between 7th, 8th


def test_the_nees_band_holds_95_percent_of_a_consistent_filters_nees() -> None:
    assert NEES_BAND == pytest.approx((0.0506356, 7.3777589), rel=1e-6)  # chi2 with 2 degrees of freedom
    draws = chi2.rvs(2, size=200_000, random_state=np.random.default_rng(5))
    assert nees_inside(draws).mean() == pytest.approx(0.95, abs=0.003)
    assert not nees_inside(np.array([np.nan, 8.0, 0.01])).any()


def test_the_longest_unseen_stretch_is_the_longest_run_of_steps_nobody_saw() -> None:
    seen = np.array([True, False, False, True, False, False, False, True, False])
    assert longest_unseen(seen) == 3
    assert longest_unseen(np.ones(5, dtype=bool)) == 0 and longest_unseen(np.zeros(4, dtype=bool)) == 4
