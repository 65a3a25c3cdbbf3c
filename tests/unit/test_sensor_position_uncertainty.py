"""The target filter takes each vehicle's own position uncertainty (the navigation filter's covariance)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter, pseudo_measurement
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection, TrackerConfig, fuse
from sim_vehicles.truth.sensor import exact_measurements

SENSOR = SensorModel.range_bearing(10.0, 0.02, 0.02)
UIF = UnscentedInformationFilter(constant_velocity(0.01))


def test_vehicle_jacobian_matches_finite_differences() -> None:
    target = np.array([1500.0, 1400.0])
    vehicle = np.array([1100.0, 1650.0, 220.0])
    jac = SENSOR.vehicle_jacobian(target, vehicle)
    eps = 1e-4
    numeric = np.column_stack([(SENSOR.measure(target, vehicle + eps * e) - SENSOR.measure(target, vehicle - eps * e))
                               / (2 * eps) for e in np.eye(3)])
    np.testing.assert_allclose(jac, numeric, rtol=1e-6, atol=1e-12)


def _prior() -> GaussianEstimate:
    return GaussianEstimate(np.array([1500.0, 1500.0, 3.0, -1.0]), np.diag([400.0, 300.0, 25.0, 25.0]), 0)


def test_zero_vehicle_covariance_is_the_exact_contribution_and_a_large_one_weakens_it() -> None:
    vehicles = np.array([[1200.0, 1300.0, 200.0], [1800.0, 1600.0, 210.0]])
    z = exact_measurements(np.array([1510.0, 1490.0, 0.0]), vehicles)
    exact = UIF.contribution(_prior(), SENSOR, z, vehicles)
    zero = UIF.contribution(_prior(), SENSOR, z, vehicles, np.zeros((2, 3, 3)))
    np.testing.assert_allclose(zero.vector, exact.vector, rtol=1e-10)
    np.testing.assert_allclose(zero.matrix, exact.matrix, rtol=1e-10)
    loose = UIF.contribution(_prior(), SENSOR, z, vehicles, np.stack([np.diag([900.0, 900.0, 0.0])] * 2))
    assert np.all(np.linalg.eigvalsh(exact.matrix - loose.matrix) > 0.0)  # strictly less information


def test_inflation_equals_the_augmented_state_update() -> None:
    """Linearised: estimating [target; vehicle] with the vehicle's prior and marginalising gives the
    same posterior as the inflated noise R + J_s P_s J_s^T."""
    prior = _prior()
    vehicle = np.array([1200.0, 1300.0, 200.0])
    p_s = np.array([[400.0, 100.0, 0.0], [100.0, 250.0, 0.0], [0.0, 0.0, 25.0]])
    z = exact_measurements(np.array([1510.0, 1490.0, 0.0]), vehicle) + [3.0, 0.01, -0.01]
    posterior = UIF.update(prior, [UIF.contribution(prior, SENSOR, z, vehicle, p_s)])
    # Augmented linear update with the same linearisation: H^p of eq. (12) for the target, J_s for the vehicle.
    plain = UIF.contribution(prior, SENSOR, z, vehicle)
    z_pred, h = pseudo_measurement(prior, SENSOR, vehicle, UIF.sigma)
    j = SENSOR.vehicle_jacobian(prior.mean[:2], vehicle)
    big_h = np.zeros((3, 7))
    big_h[:, :2], big_h[:, 4:] = h, j
    big_p = np.zeros((7, 7))
    big_p[:4, :4], big_p[4:, 4:] = prior.cov, p_s
    s = big_h @ big_p @ big_h.T + np.diag(UIF.noise_variance(prior, SENSOR, z_pred, vehicle, p_s))  # R, second order included
    gain = big_p @ big_h.T @ np.linalg.inv(s)
    nu = SENSOR.residual(z, z_pred)
    np.testing.assert_allclose(posterior.mean, prior.mean + (gain @ nu)[:4], rtol=1e-9)
    np.testing.assert_allclose(posterior.cov, (big_p - gain @ s @ gain.T)[:4, :4], rtol=1e-7)
    assert not np.allclose(posterior.cov, UIF.update(prior, [plain]).cov, rtol=1e-3)


@pytest.mark.parametrize("with_cov", [True, False])
def test_fused_track_is_consistent_only_when_the_navigation_error_is_accounted(with_cov: bool) -> None:
    """Vehicles report positions off by N(0, 30^2) m per axis (fresh every report): the DUIF's NEES is
    in its chi-square band with the covariance, far above it without."""
    config = TrackerConfig(uif=UIF, sensors=(SENSOR,) * 3, planner=None, max_turn_rate=np.zeros(3))
    runs, steps = 30, 30
    nav_cov = np.diag([900.0, 900.0])
    nees = np.zeros((runs, steps))
    for run in range(runs):
        rng = np.random.default_rng([21, run])
        truth = np.array([1500.0, 1500.0, 3.0, -1.0])
        estimate = GaussianEstimate(truth + rng.normal(size=4) * [20.0, 20.0, 5.0, 5.0],
                                    np.diag([400.0, 400.0, 25.0, 25.0]), 0)
        for k in range(1, steps + 1):
            truth = truth + [truth[2], truth[3], 0.0, 0.0]
            angles = 2 * np.pi * np.arange(3) / 3 + 0.08 * k
            vehicles = np.column_stack([truth[0] + 400 * np.cos(angles), truth[1] + 400 * np.sin(angles),
                                        [200.0, 210.0, 220.0]])
            z = exact_measurements(np.append(truth[:2], 0.0), vehicles) + rng.normal(size=(3, 3)) * SENSOR.std
            reported = vehicles + np.column_stack([rng.normal(size=(3, 2)) * 30.0, np.zeros(3)])
            detections = [Detection(i, reported[i], z[i], nav_cov if with_cov else None) for i in range(3)]
            estimate = fuse(config, estimate, k * 1_000_000_000, detections)
            e = estimate.mean - truth
            nees[run, k - 1] = e @ np.linalg.solve(estimate.cov, e)
    lo, hi = chi2.ppf([0.0005, 0.9995], 4 * runs) / runs
    if with_cov:
        assert lo < nees[:, 5:].mean() < hi
    else:
        assert nees[:, 5:].mean() > 3 * hi


def test_detection_rejects_a_bad_covariance() -> None:
    with pytest.raises(ValueError, match="vehicle_cov"):
        Detection(0, np.zeros(3), np.zeros(3), np.eye(4))
    with pytest.raises(ValueError, match="vehicle_cov"):
        Detection(0, np.zeros(3), np.zeros(3), np.array([[np.nan, 0.0], [0.0, 1.0]]))
    d = Detection(0, np.zeros(3), np.zeros(3), np.array([[4.0, 1.0], [1.0, 9.0]]))
    np.testing.assert_array_equal(d.position_cov, [[4.0, 1.0, 0.0], [1.0, 9.0, 0.0], [0.0, 0.0, 0.0]])


def test_per_axis_variances_take_the_diagonal_path_with_the_full_paths_result() -> None:
    """``s^2`` per vehicle (a report's std) and the matrix ``s^2 I`` must give the same contribution and R."""
    prior = _prior()
    vehicles = np.array([[1200.0, 1300.0, 200.0], [1495.0, 1503.0, 210.0]])  # the second nearly overhead
    z = exact_measurements(np.array([1510.0, 1490.0, 0.0]), vehicles)
    per_axis = np.array([6.25, 2.0])
    matrices = per_axis[:, None, None] * np.eye(3)
    cheap = UIF.contribution(prior, SENSOR, z, vehicles, per_axis)
    full = UIF.contribution(prior, SENSOR, z, vehicles, matrices)
    np.testing.assert_allclose(cheap.matrix, full.matrix, rtol=1e-9)
    np.testing.assert_allclose(cheap.vector, full.vector, rtol=1e-9)
    z_pred, _ = pseudo_measurement(prior, SENSOR, vehicles, UIF.sigma)
    np.testing.assert_allclose(UIF.noise_covariance(prior, SENSOR, z_pred, vehicles, per_axis),
                               UIF.noise_covariance(prior, SENSOR, z_pred, vehicles, matrices), rtol=1e-9, atol=1e-15)
    exact = UIF.contribution(prior, SENSOR, z, vehicles)
    assert np.all(np.linalg.eigvalsh(exact.matrix - cheap.matrix) > 0.0)  # the uncertainty costs information


def test_a_detection_takes_a_per_axis_variance_and_refuses_a_bad_one() -> None:
    detection = Detection(0, np.zeros(3), np.zeros(3), vehicle_cov=4)
    assert detection.vehicle_cov == 4.0 and np.array_equal(detection.position_cov, 4.0 * np.eye(3))
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="per-axis"):
            Detection(0, np.zeros(3), np.zeros(3), vehicle_cov=bad)


def test_the_isotropic_vehicle_term_is_the_diagonal_of_j_s_p_s_j_s_and_that_is_all_of_it() -> None:
    """Oracle: ``J_s (s^2 I) J_s^T`` from the vehicle Jacobian; its off-diagonal vanishes (orthogonal gradients)."""
    rng = np.random.default_rng(5)
    targets = rng.uniform(0.0, 3000.0, (20, 2))
    vehicles = np.column_stack([rng.uniform(0.0, 3000.0, (20, 2)), rng.uniform(100.0, 300.0, 20)])
    var = rng.uniform(0.5, 30.0, 20)
    jac = SENSOR.vehicle_jacobian(targets, vehicles)
    full = var[:, None, None] * (jac @ jac.swapaxes(-1, -2))
    np.testing.assert_allclose(SENSOR.isotropic_vehicle_variance(targets, vehicles, var),
                               np.diagonal(full, axis1=-2, axis2=-1), rtol=1e-12)
    off_diagonal = full - np.einsum("kii->ki", full)[..., None] * np.eye(3)
    assert np.abs(off_diagonal).max() < 1e-12 * np.abs(full).max()
