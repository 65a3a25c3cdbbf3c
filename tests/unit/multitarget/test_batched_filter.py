"""The batched filter equals the per-track reference (covariance form) on random cases."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.reference import reference_assigned_update, reference_mixture_update, reference_predict

from ._cases import SENSORS, random_tracks, random_vehicle

MOTION = constant_velocity(0.5)
SEEDS = range(12)


def _scene(seed: int):
    rng = np.random.default_rng(seed)
    count = int(rng.integers(1, 7))
    mean, cov = random_tracks(rng, count)
    vehicles = []
    for v in range(int(rng.integers(1, 4))):
        sensor = SENSORS[(seed + v) % len(SENSORS)]
        seen = mean[rng.random(count) < 0.8, :2]
        vehicles.append(random_vehicle(rng, sensor, seen, int(rng.integers(0, 4)), uncertain=bool(v % 2)))
    return rng, mean, cov, vehicles


def _random_assignment(rng: np.random.Generator, tracks: int, detections: int) -> np.ndarray:
    chosen = np.full(tracks, -1, dtype=np.int64)
    order = rng.permutation(detections)[:tracks]
    keep = rng.random(order.size) < 0.8
    chosen[np.flatnonzero(keep)] = order[keep]
    return chosen


def _random_beta(rng: np.random.Generator, tracks: int, detections: int) -> np.ndarray:
    weights = rng.random((tracks, detections + 1)) * (rng.random((tracks, detections + 1)) < 0.6)
    weights[:, -1] += 0.05  # every track may be missed
    return (weights / weights.sum(axis=1, keepdims=True))[:, :detections]


def _fused(mean, cov, vehicles, associations, contributions):
    """The batched update: each vehicle's contributions for its association, summed (eq. 14), fused (eq. 15)."""
    a_sum, b_sum = np.zeros((mean.shape[0], 2, 2)), np.zeros((mean.shape[0], 2))
    for (sensor, z, xyz, pcov), association in zip(vehicles, associations):
        a, b = contributions(batched.innovations(mean, cov, sensor, z, xyz, pcov), association)
        a_sum += a
        b_sum += b
    return batched.information_update(mean, cov, a_sum, b_sum)


@pytest.mark.parametrize("seed", SEEDS)
def test_predict_equals_reference(seed: int) -> None:
    _, mean, cov, _ = _scene(seed)
    got = batched.predict(mean, cov, 0.7, MOTION)
    want = reference_predict(mean, cov, 0.7, MOTION)
    np.testing.assert_allclose(got[0], want[0], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
def test_assigned_update_equals_stacked_kalman_update(seed: int) -> None:
    rng, mean, cov, vehicles = _scene(seed)
    assigned = [_random_assignment(rng, mean.shape[0], z.shape[0]) for _, z, _, _ in vehicles]
    got_mean, got_cov = _fused(mean, cov, vehicles, assigned, batched.assigned_contributions)
    want_mean, want_cov = reference_assigned_update(mean, cov, vehicles, assigned)
    np.testing.assert_allclose(got_mean, want_mean, rtol=1e-9, atol=1e-7)
    np.testing.assert_allclose(got_cov, want_cov, rtol=1e-8, atol=1e-7)
    assert any((c >= 0).any() for c in assigned) is bool(np.abs(got_mean - mean).max() > 0)


@pytest.mark.parametrize("seed", SEEDS)
def test_mixture_update_equals_moment_matched_mixtures_fused(seed: int) -> None:
    rng, mean, cov, vehicles = _scene(seed)
    betas = [_random_beta(rng, mean.shape[0], z.shape[0]) for _, z, _, _ in vehicles]
    got_mean, got_cov = _fused(mean, cov, vehicles, betas,
                               lambda inn, beta: batched.mixture_contributions(inn, beta, cov[:, :2, :2]))
    want_mean, want_cov = reference_mixture_update(mean, cov, vehicles, betas)
    np.testing.assert_allclose(got_mean, want_mean, rtol=1e-7, atol=1e-5)
    np.testing.assert_allclose(got_cov, want_cov, rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("seed", SEEDS)
def test_one_hot_mixture_is_the_assigned_update(seed: int) -> None:
    rng, mean, cov, vehicles = _scene(seed)
    sensor, z, xyz, pcov = vehicles[0]
    chosen = _random_assignment(rng, mean.shape[0], z.shape[0])
    beta = np.zeros((mean.shape[0], z.shape[0]))
    beta[np.flatnonzero(chosen >= 0), chosen[chosen >= 0]] = 1.0
    inn = batched.innovations(mean, cov, sensor, z, xyz, pcov)
    a_mix, b_mix = batched.mixture_contributions(inn, beta, cov[:, :2, :2])
    a_one, b_one = batched.assigned_contributions(inn, chosen)
    scale = np.abs(a_one).max() + 1e-12
    np.testing.assert_allclose(a_mix / scale, a_one / scale, atol=1e-6)
    np.testing.assert_allclose(b_mix, b_one, rtol=1e-5, atol=1e-6 * np.abs(b_one).max() + 1e-12)


def test_innovations_wrap_the_azimuth_across_the_seam() -> None:
    sensor = SENSORS[0]
    mean = np.array([[-1000.0, 1e-3, 0.0, 0.0]])
    cov = np.diag([100.0, 100.0, 1.0, 1.0])[None]
    xyz = np.zeros((1, 3))
    z = sensor.measure(np.array([[-1000.0, -1e-3]]), xyz)  # azimuth just below -pi, the track's just below pi
    inn = batched.innovations(mean, cov, sensor, z, xyz, np.zeros((1, 3, 3)))
    assert abs(inn.nu[0, 0, 1]) < 1e-5
