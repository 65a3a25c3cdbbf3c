"""k+n prediction (wang2012 eq. 16-17) and expected information of candidates (eq. 18)."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.prediction import expected_information, predict_horizon
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
UIF = UnscentedInformationFilter(constant_velocity(1.96))
POSTERIOR = GaussianEstimate(np.array([1500.0, 1500.0, 6.0, -2.0]), np.diag([30.0, 20.0, 4.0, 3.0]), 7_000_000_000)


def test_horizon_follows_the_motion_model_with_growing_covariance() -> None:
    prediction = predict_horizon(UIF, POSTERIOR, 1.0, 5)
    f, q = UIF.motion.matrices(1.0)
    mean, cov = POSTERIOR.mean, POSTERIOR.cov
    for j in range(5):
        mean, cov = f @ mean, f @ cov @ f.T + q
        np.testing.assert_allclose(prediction.states.mean[j], mean, rtol=1e-12)
        np.testing.assert_allclose(prediction.states.cov[j], cov, rtol=1e-12)
    assert prediction.stamps_ns == tuple(7_000_000_000 + j * 1_000_000_000 for j in range(1, 6))
    traces = np.trace(prediction.states.cov[:, :2, :2], axis1=1, axis2=2)
    assert np.all(np.diff(traces) > 0)
    np.testing.assert_allclose(prediction.positions[-1], POSTERIOR.mean[:2] + 5 * POSTERIOR.mean[2:])
    with pytest.raises(ValueError):
        predict_horizon(UIF, POSTERIOR, 1.0, 0)


def test_expected_information_equals_the_filters_contribution_for_each_candidate() -> None:
    prediction = predict_horizon(UIF, POSTERIOR, 1.0, 4)
    rng = np.random.default_rng(3)
    candidates = np.concatenate([rng.uniform(800, 2200, size=(6, 2, 4, 2)), np.full((6, 2, 4, 1), 210.0)], axis=-1)
    info = expected_information(UIF, prediction, SENSOR, candidates)
    assert info.shape == (6, 2, 4, 2, 2)
    for c, v, j in [(0, 0, 0), (3, 1, 2), (5, 0, 3)]:
        step = GaussianEstimate(prediction.states.mean[j], prediction.states.cov[j], prediction.stamps_ns[j])
        vehicle = candidates[c, v, j]
        contribution = UIF.contribution(step, SENSOR, SENSOR.measure(step.mean, vehicle), vehicle)
        np.testing.assert_allclose(info[c, v, j], contribution.matrix, rtol=1e-10)


def test_expected_information_falls_with_distance() -> None:
    prediction = predict_horizon(UIF, POSTERIOR, 1.0, 1)
    target = prediction.positions[0]
    near = np.array([[target[0] + 300.0, target[1], 200.0]])
    far = np.array([[target[0] + 3000.0, target[1], 200.0]])
    info_near = expected_information(UIF, prediction, SENSOR, near)
    info_far = expected_information(UIF, prediction, SENSOR, far)
    assert np.linalg.det(info_near[0]) > 10 * np.linalg.det(info_far[0])
