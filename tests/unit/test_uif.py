"""Unscented information filter and DUIF fusion (wang2012 eq. 7-15), against independent oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter, pseudo_measurement
from gcs.core.models.motion import constant_acceleration, constant_velocity
from gcs.core.models.sensor import SensorModel

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
UIF = UnscentedInformationFilter(constant_velocity(1.96))
VEHICLES = np.array([[1200.0, 1200.0, 200.0], [1800.0, 1200.0, 210.0], [1500.0, 1900.0, 220.0]])


def _prior(spread: float = 40.0) -> GaussianEstimate:
    correlation = np.array([[1.0, 0.3, 0.5, 0.1], [0.3, 1.0, -0.2, 0.4], [0.5, -0.2, 1.0, 0.1], [0.1, 0.4, 0.1, 1.0]])
    scale = np.diag([spread, 0.9 * spread, 5.0, 4.0])
    return GaussianEstimate(np.array([1500.0, 1450.0, 5.0, -2.0]), scale @ correlation @ scale, 0)


def _observe(target: np.ndarray, vehicle: np.ndarray) -> np.ndarray:
    """Range, azimuth, elevation by the test's own formulas."""
    d = np.append(target[:2], 0.0) - vehicle
    return np.array([np.linalg.norm(d), math.atan2(d[1], d[0]), math.atan2(d[2], math.hypot(d[0], d[1]))])


def _full_state_ut(prior: GaussianEstimate, vehicle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Textbook unscented transform over all 2n+1 points; H^p = P_xz^T P^-1 (Lee 2008)."""
    n = prior.mean.size
    lam = 1.0 * (n + (3 - n)) - n
    root = np.linalg.cholesky((n + lam) * prior.cov)
    chi = [prior.mean] + [prior.mean + root[:, j] for j in range(n)] + [prior.mean - root[:, j] for j in range(n)]
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wm[0] = lam / (n + lam)
    wc = wm.copy()
    wc[0] += 2.0
    z = np.array([_observe(c, vehicle) for c in chi])
    z[:, 1] = z[0, 1] + np.angle(np.exp(1j * (z[:, 1] - z[0, 1])))  # unwrap about the centre point
    z_mean = wm @ z
    dz = z - z_mean
    p_xz = sum(wc[j] * np.outer(chi[j] - prior.mean, dz[j]) for j in range(2 * n + 1))
    return z_mean, p_xz.T @ np.linalg.inv(prior.cov)


@settings(max_examples=60)
@given(st.floats(-2000, 2000), st.floats(-2000, 2000), st.floats(100, 400), st.floats(5.0, 80.0))
def test_pseudo_measurement_equals_the_full_state_unscented_transform(ex: float, ey: float, h: float, spread: float) -> None:
    prior = _prior(spread)
    vehicle = prior.mean[:3] * [1, 1, 0] + [ex, ey, h]
    if math.hypot(ex, ey) < 300.0:
        return
    z_pred, h_pos = pseudo_measurement(prior, SENSOR, vehicle, UIF.sigma)
    z_ref, h_ref = _full_state_ut(prior, vehicle)
    np.testing.assert_allclose(z_pred, z_ref, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(h_pos, h_ref[:, :2], rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(h_ref[:, 2:], 0.0, atol=1e-9 * np.abs(h_ref).max())


def test_fusion_equals_information_form_eq14_eq15() -> None:
    prior = _prior()
    z = np.array([_observe(prior.mean + [8.0, -5.0, 0, 0], v) for v in VEHICLES])
    contribution = UIF.contribution(prior, SENSOR, z, VEHICLES)
    posterior = UIF.update(prior, [contribution])
    vectors, matrices = contribution.full(4)
    info = np.linalg.inv(prior.cov) + matrices.sum(axis=0)  # eq. (14)
    info_vector = np.linalg.inv(prior.cov) @ prior.mean + vectors.sum(axis=0)
    np.testing.assert_allclose(posterior.cov, np.linalg.inv(info), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(posterior.mean, np.linalg.solve(info, info_vector), rtol=1e-10)  # eq. (15)
    np.testing.assert_allclose(posterior.information_matrix, info, rtol=1e-8)


def test_each_vehicle_contributes_on_its_own_and_the_sum_is_order_free() -> None:
    prior = _prior()
    z = np.array([_observe(prior.mean + [3.0, 4.0, 0, 0], v) + [1.0, 0.01, -0.01] for v in VEHICLES])
    batch = UIF.contribution(prior, SENSOR, z, VEHICLES)
    singles = [UIF.contribution(prior, SENSOR, z[v], VEHICLES[v]) for v in range(3)]
    for v, single in enumerate(singles):
        np.testing.assert_allclose(single.vector, batch.vector[v], rtol=1e-12)
        np.testing.assert_allclose(single.matrix, batch.matrix[v], rtol=1e-12)
    forward = UIF.update(prior, singles)
    backward = UIF.update(prior, singles[::-1])
    np.testing.assert_allclose(forward.mean, backward.mean, rtol=1e-12)
    np.testing.assert_allclose(UIF.update(prior, [batch]).mean, forward.mean, rtol=1e-12)


def test_missed_detections_contribute_nothing() -> None:
    prior = _prior()
    assert UIF.update(prior, []) is prior
    z = np.array([_observe(prior.mean, v) for v in VEHICLES])
    seen = np.array([True, False, True])
    partial = UIF.update(prior, [UIF.contribution(prior, SENSOR, z[seen], VEHICLES[seen])])
    by_hand = UIF.update(prior, [UIF.contribution(prior, SENSOR, z[i], VEHICLES[i]) for i in (0, 2)])
    np.testing.assert_allclose(partial.mean, by_hand.mean, rtol=1e-12)
    full = UIF.update(prior, [UIF.contribution(prior, SENSOR, z, VEHICLES)])
    assert np.trace(full.cov) < np.trace(partial.cov) < np.trace(prior.cov)


def test_noiseless_measurements_give_near_zero_error() -> None:
    truth = np.array([1500.0, 1500.0, 6.0, -3.0])
    estimate = GaussianEstimate(truth + [40.0, -30.0, 5.0, 5.0], np.diag([2500.0, 2500.0, 100.0, 100.0]), 0)
    for k in range(200):
        state = truth + k * np.array([truth[2], truth[3], 0.0, 0.0])
        prior = UIF.predict(estimate, k * 1_000_000_000)
        z = np.array([_observe(state, v) for v in VEHICLES + [state[0] - 1500.0, state[1] - 1500.0, 0.0]])
        estimate = UIF.update(prior, [UIF.contribution(prior, SENSOR, z, VEHICLES + [state[0] - 1500, state[1] - 1500, 0])])
    assert np.linalg.norm(estimate.mean[:2] - state[:2]) < 0.05
    assert np.linalg.norm(estimate.mean[2:] - state[2:]) < 0.01


def _track_past_the_seam(rotation: float) -> np.ndarray:
    """A target passing west of a single vehicle, through azimuth +-pi, in a rotated frame."""
    rot = np.array([[math.cos(rotation), -math.sin(rotation)], [math.sin(rotation), math.cos(rotation)]])
    rng = np.random.default_rng(5)
    vehicle = np.array([0.0, 0.0, 200.0])
    start, velocity = np.array([-600.0, 200.0]), np.array([0.0, -8.0])
    cov = np.diag([900.0, 900.0, 25.0, 25.0])
    cov[:2, :2] = rot @ cov[:2, :2] @ rot.T
    estimate = GaussianEstimate(np.concatenate([rot @ (start + [20, -10]), rot @ velocity]), cov, 0)
    errors = []
    for k in range(50):
        truth = rot @ (start + k * velocity)
        z = _observe(truth, vehicle) + rng.normal(size=3) * [10.0, 0.05, 0.05]
        z[1] = (z[1] + math.pi) % (2 * math.pi) - math.pi
        prior = UIF.predict(estimate, k * 1_000_000_000)
        estimate = UIF.update(prior, [UIF.contribution(prior, SENSOR, z[None], vehicle[None])])
        errors.append(rot.T @ (estimate.mean[:2] - truth))
    return np.array(errors)


def test_target_crossing_the_azimuth_seam_is_tracked_like_anywhere_else() -> None:
    at_seam = _track_past_the_seam(0.0)  # azimuth passes through +-pi
    rotated = _track_past_the_seam(math.pi / 2)  # same geometry, azimuth near -pi/2
    # The Cholesky square root is not rotation invariant, so the two runs differ at
    # second order (millimetres); a seam bug would show as hundreds of metres.
    np.testing.assert_allclose(at_seam, rotated, atol=0.05)
    assert np.sqrt(np.mean(at_seam[10:] ** 2)) < 15.0


def test_six_state_model_runs_and_keeps_acceleration_uncertain_but_bounded() -> None:
    uif = UnscentedInformationFilter(constant_acceleration(0.1))
    estimate = GaussianEstimate(np.array([1500.0, 1500.0, 0, 0, 0, 0]), np.diag([2500.0, 2500, 100, 100, 4, 4]), 0)
    for k in range(1, 30):
        prior = uif.predict(estimate, k * 1_000_000_000)
        state = np.array([1500.0 + 0.05 * k * k, 1500.0])
        z = np.array([_observe(state, v) for v in VEHICLES])
        estimate = uif.update(prior, [uif.contribution(prior, SENSOR, z, VEHICLES)])
    assert estimate.mean.shape == (6,)
    assert abs(estimate.mean[4] - 0.1) < 0.05
    assert np.all(np.linalg.eigvalsh(estimate.cov) > 0)


def test_predicting_backwards_is_an_error() -> None:
    with pytest.raises(ValueError, match="backwards"):
        UIF.predict(GaussianEstimate(np.zeros(4), np.eye(4), 10), 5)


@pytest.mark.parametrize("truth", [(-3.0, 2.0), (-6.0, -4.0), (2.0, 8.0)])
def test_a_detection_from_right_above_the_target_leaves_the_estimate_consistent(truth: tuple[float, float]) -> None:
    """Under the vehicle the azimuth's sigma points straddle it; eq. (13) as printed then claims
    far more than the measurement holds, and the second-order term (the default) does not."""
    vehicle = np.array([0.0, 0.0, 200.0])
    truth_xy = np.array(truth)
    z = SENSOR.measure(truth_xy, vehicle)  # noise-free: any error is the filter's
    prior = GaussianEstimate(np.array([8.0, -5.0, 0.0, 0.0]), np.diag([100.0, 100.0, 4.0, 4.0]), 0)

    def nees(uif: UnscentedInformationFilter) -> float:
        posterior = uif.update(prior, [uif.contribution(prior, SENSOR, z, vehicle)])
        error = posterior.mean[:2] - truth_xy
        return float(error @ np.linalg.solve(posterior.cov[:2, :2], error))

    assert nees(UIF) < 9.21  # chi-square, 2 degrees of freedom, 99%
    assert nees(UnscentedInformationFilter(UIF.motion, second_order=False)) > 100.0
