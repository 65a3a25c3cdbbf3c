"""PCRLB (Tichavsky recursion): Fisher information vs numerics, and its recursion's limits."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.pcrlb import measurement_information, pcrlb

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
MOTION = constant_velocity(1.96)
P0 = np.diag([2500.0, 2500.0, 100.0, 100.0])


def _numerical_fisher(state: np.ndarray, vehicle: np.ndarray, sensor: SensorModel) -> np.ndarray:
    """E[score score^T] for z ~ N(h(x), R) with h differentiated numerically: J^T R^-1 J."""
    jac = np.zeros((sensor.dim, state.size))
    for j in range(state.size):
        step = np.zeros(state.size)
        step[j] = 1e-4
        diff = sensor.measure(state + step, vehicle) - sensor.measure(state - step, vehicle)
        jac[:, j] = diff / 2e-4
    return jac.T @ np.diag(1.0 / np.square(sensor.std)) @ jac


def test_measurement_information_matches_numerical_fisher_information() -> None:
    state = np.array([1500.0, 1400.0, 3.0, 1.0])
    vehicles = np.array([[[1200.0, 1200.0, 200.0], [1900.0, 1300.0, 210.0]]])
    info = measurement_information([SENSOR, SENSOR], vehicles, np.ones((1, 2), bool), state[None], 4)
    expected = sum(_numerical_fisher(state, v, SENSOR) for v in vehicles[0])
    np.testing.assert_allclose(info[0], expected, rtol=1e-6, atol=1e-12)


def test_without_detections_the_bound_is_pure_prediction() -> None:
    k = 6
    truth = np.tile([1500.0, 1500.0, 5.0, 0.0], (k, 1))
    vehicles = np.tile([[1200.0, 1200.0, 200.0]], (k, 1, 1))
    bound = pcrlb(MOTION, 1.0, P0, [SENSOR], vehicles, np.zeros((k, 1), bool), truth)
    f, q = MOTION.matrices(1.0)
    expected = P0
    np.testing.assert_allclose(bound[0], P0)
    for step in range(1, k):
        expected = f @ expected @ f.T + q
        np.testing.assert_allclose(bound[step], expected, rtol=1e-9)


def test_more_vehicles_and_more_detections_lower_the_bound() -> None:
    k = 20
    truth = np.tile([1500.0, 1500.0, 0.0, 0.0], (k, 1))
    vehicles = np.tile([[1200.0, 1200.0, 200.0], [1800.0, 1200.0, 210.0], [1500.0, 1900.0, 220.0]], (k, 1, 1))
    all_seen = np.ones((k, 3), bool)
    one = pcrlb(MOTION, 1.0, P0, [SENSOR], vehicles[:, :1], all_seen[:, :1], truth)
    three = pcrlb(MOTION, 1.0, P0, [SENSOR] * 3, vehicles, all_seen, truth)
    gaps = all_seen.copy()
    gaps[5:10, :2] = False
    occluded = pcrlb(MOTION, 1.0, P0, [SENSOR] * 3, vehicles, gaps, truth)
    pos = lambda b: np.trace(b[:, :2, :2], axis1=1, axis2=2)  # noqa: E731
    assert np.all(pos(three) < pos(one))
    assert np.all(pos(occluded)[5:10] > pos(three)[5:10])
    np.testing.assert_allclose(pos(occluded)[:5], pos(three)[:5])


def test_sample_axis_averages_the_fisher_information() -> None:
    truths = np.array([[[1500.0, 1500.0, 0, 0]], [[1600.0, 1500.0, 0, 0]]])
    vehicles = np.array([[[1200.0, 1200.0, 200.0]]])
    both = measurement_information([SENSOR], vehicles, np.ones((1, 1), bool), truths, 4)
    each = [measurement_information([SENSOR], vehicles, np.ones((1, 1), bool), t, 4) for t in truths]
    np.testing.assert_allclose(both, 0.5 * (each[0] + each[1]))
    with pytest.raises(ValueError, match="sensors"):
        measurement_information([SENSOR, SENSOR], vehicles, np.ones((1, 1), bool), truths, 4)
