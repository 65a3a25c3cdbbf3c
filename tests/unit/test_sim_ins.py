"""Simulated INS increments: scale error, drift, per-sqrt-second noise, clipping."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom, chi2

from gcs.config.simulation import InsConfig
from sim_vehicles.truth.ins import InsModel

ALPHA = 1e-4
"""Two-sided false-alarm probability of every statistical check."""
Z = 4.42
"""Two-sided normal bound for 1e-5."""

CFG = InsConfig(distance_scale_error=0.02, distance_std_m=0.5, heading_drift_rad_s=0.001, heading_std_rad=0.003)


def _draw(model: InsModel, distance: float, turn: float, dt: float, seed: int, n: int = 4000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.array([model.increment(distance, turn, dt, rng) for _ in range(n)])


@pytest.mark.parametrize("dt", [0.5, 2.0, 8.0])
def test_mean_and_variance_match_the_config(dt: float) -> None:
    samples = _draw(InsModel(CFG), 100.0, 0.05, dt, seed=int(dt * 10))
    expected_mean = np.array([100.0 * (1 + CFG.distance_scale_error), 0.05 + CFG.heading_drift_rad_s * dt])
    expected_var = np.array([CFG.distance_std_m**2, CFG.heading_std_rad**2]) * dt  # random walks: variance ~ dt
    n = len(samples)
    assert np.all(np.abs(samples.mean(axis=0) - expected_mean) < Z * np.sqrt(expected_var / n))
    lo, hi = chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], n)
    statistic = np.sum((samples - expected_mean) ** 2 / expected_var, axis=0)
    assert np.all((lo < statistic) & (statistic < hi)), statistic


def test_noiseless_increments_carry_only_scale_error_and_drift() -> None:
    model = InsModel(InsConfig(distance_scale_error=-0.1, distance_std_m=0.0, heading_drift_rad_s=0.01,
                               heading_std_rad=0.0))
    distance, turn = model.increment(50.0, -0.2, 3.0, np.random.default_rng(1))
    assert distance == pytest.approx(45.0)
    assert turn == pytest.approx(-0.2 + 0.03)


def test_distance_is_clipped_at_zero() -> None:
    samples = _draw(InsModel(CFG), 0.0, 0.0, 1.0, seed=3, n=2000)
    assert np.all(samples[:, 0] >= 0.0)
    zeros = int(np.sum(samples[:, 0] == 0.0))  # half the noise is negative
    lo, hi = binom.ppf([ALPHA / 2, 1 - ALPHA / 2], len(samples), 0.5)
    assert lo <= zeros <= hi


def test_equal_seeds_give_equal_increments_and_bad_intervals_are_rejected() -> None:
    model = InsModel(CFG)
    np.testing.assert_array_equal(_draw(model, 10.0, 0.1, 1.0, seed=4, n=5), _draw(model, 10.0, 0.1, 1.0, seed=4, n=5))
    with pytest.raises(ValueError, match="dt_s"):
        model.increment(1.0, 0.0, -0.1, np.random.default_rng(0))
    assert math.isfinite(model.increment(1.0, 0.0, 0.0, np.random.default_rng(0))[0])
