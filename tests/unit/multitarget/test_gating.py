"""The chi-square gate: its threshold is the chi-square quantile, and it holds P_G of the true detections."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom, chi2

from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.gating import gate, gate_threshold

from ._cases import SENSORS, random_tracks, random_vehicle


@pytest.mark.parametrize(("probability", "dim"), [(0.9, 1), (0.99, 2), (0.999, 3), (0.95, 3)])
def test_threshold_is_the_chi_square_quantile(probability: float, dim: int) -> None:
    assert gate_threshold(probability, dim) == pytest.approx(chi2.ppf(probability, dim), rel=1e-12)
    assert chi2.cdf(gate_threshold(probability, dim), dim) == pytest.approx(probability, abs=1e-12)


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.1, 1.5])
def test_threshold_refuses_a_probability_outside_0_1(bad: float) -> None:
    with pytest.raises(ValueError, match="gate probability"):
        gate_threshold(bad, 2)


@pytest.mark.parametrize("seed", range(6))
def test_gate_is_the_mahalanobis_test_of_every_pair(seed: int) -> None:
    rng = np.random.default_rng(seed)
    mean, cov = random_tracks(rng, 5)
    sensor, z, xyz, pcov = random_vehicle(rng, SENSORS[seed % len(SENSORS)], mean[:3, :2], 4, uncertain=True)
    inn = batched.innovations(mean, cov, sensor, z, xyz, pcov)
    valid = gate(inn.d2, 0.99, sensor.dim)
    gamma = chi2.ppf(0.99, sensor.dim)
    for t in range(mean.shape[0]):
        for j in range(z.shape[0]):
            nu = inn.nu[t, j]
            d2 = nu @ np.linalg.solve(inn.s[t, j], nu)
            assert d2 == pytest.approx(inn.d2[t, j], rel=1e-8)
            assert valid[t, j] == (d2 <= gamma)


@pytest.mark.parametrize(("probability", "dim"), [(0.9, 2), (0.99, 3)])
def test_gate_holds_p_g_of_gaussian_innovations(probability: float, dim: int) -> None:
    rng = np.random.default_rng(7)
    root = rng.normal(size=(dim, dim)) + dim * np.eye(dim)
    s = root @ root.T
    nu = rng.normal(size=(20_000, dim)) @ np.linalg.cholesky(s).T
    d2 = np.einsum("ki,ij,kj->k", nu, np.linalg.inv(s), nu)[None, :]
    inside = int(gate(d2, probability, dim).sum())
    low, high = binom.interval(0.999, nu.shape[0], probability)
    assert low <= inside <= high
