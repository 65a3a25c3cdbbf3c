"""The batched routeless navigation filter equals the one-vehicle filter, whatever shares the batch."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.kalman import Observation, kalman_update, stack_observations
from gcs.core.navigation.fleet_ekf import GPS_ROWS, HEADING_ROWS, VELOCITY_ROWS, ins_predict_many, update_many
from gcs.core.navigation.model import InsNoise, gps_observation, heading_observation, ins_predict, velocity_observation

NOISE = InsNoise()


def _states(rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    means = np.column_stack([rng.uniform(-3000, 3000, (count, 2)), rng.uniform(-np.pi, np.pi, count),
                             rng.normal(0, 20, (count, 2)), rng.normal(0, 0.1, count)])
    roots = rng.normal(0, 1, (count, 6, 6)) * np.array([5, 5, 0.05, 1, 1, 0.01])[:, None]
    return means, roots @ roots.swapaxes(-1, -2) + 1e-3 * np.eye(6)


def _close(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * max(1.0, float(np.abs(b).max())))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_batched_ins_prediction_is_eq_1_for_each_vehicle(seed: int) -> None:
    rng = np.random.default_rng(seed)
    means, covs = _states(rng, 7)
    ds, dth, dt = rng.uniform(0, 10, 7), rng.normal(0, 0.05, 7), rng.uniform(0.1, 0.3, 7)
    new, predicted = ins_predict_many(means, covs, ds, dth, dt, NOISE)
    for v in range(7):
        one_mean, one_cov = ins_predict(means[v], covs[v], ds[v], dth[v], dt[v], NOISE)
        _close(new[v], one_mean)
        _close(predicted[v], one_cov)
        np.testing.assert_array_equal(predicted[v], predicted[v].T)


@pytest.mark.parametrize("rows", [GPS_ROWS + VELOCITY_ROWS + HEADING_ROWS, GPS_ROWS, HEADING_ROWS,
                                  GPS_ROWS + HEADING_ROWS])
def test_the_batched_update_is_the_kalman_update_of_each_vehicle(rows: tuple[int, ...]) -> None:
    rng = np.random.default_rng(len(rows))
    means, covs = _states(rng, 5)
    values = means[:, list(rows)] + rng.normal(0, 2, (5, len(rows)))
    if 2 in rows:  # a heading across the seam: the residual must be wrapped
        values[:, rows.index(2)] = np.where(values[:, rows.index(2)] > 0, values[:, rows.index(2)] - 2 * np.pi,
                                            values[:, rows.index(2)] + 2 * np.pi)
    variances = rng.uniform(0.1, 9.0, (5, len(rows)))
    new, post = update_many(means, covs, rows, values, variances)
    for v in range(5):
        parts, column = [], 0
        for group, make in ((GPS_ROWS, gps_observation), (VELOCITY_ROWS, velocity_observation),
                            (HEADING_ROWS, heading_observation)):
            if group[0] in rows:
                width = len(group)
                z, var = values[v, column:column + width], variances[v, column:column + width]
                if make is heading_observation:
                    parts.append(make(float(z[0]), float(np.sqrt(var[0]))))
                elif make is gps_observation:
                    parts.append(make(z, np.diag(var)))
                else:  # the GNSS velocity, with a variance of its own per axis
                    observation = make(z, 1.0)
                    parts.append(Observation(observation.z, observation.h, np.diag(var)))
                column += width
        one_mean, one_cov, _ = kalman_update(means[v], covs[v], stack_observations(parts))
        _close(new[v], one_mean)
        _close(post[v], one_cov)


def test_a_vehicles_result_does_not_depend_on_what_shares_its_batch() -> None:
    # the daemon and the replay may batch differently: each vehicle's numbers must be its own, bit for bit
    rng = np.random.default_rng(7)
    means, covs = _states(rng, 7)
    ds, dth, dt = rng.uniform(0, 10, 7), rng.normal(0, 0.05, 7), rng.uniform(0.1, 0.3, 7)
    rows = GPS_ROWS + VELOCITY_ROWS + HEADING_ROWS
    values, variances = means[:, list(rows)] + rng.normal(0, 2, (7, 5)), rng.uniform(0.1, 9.0, (7, 5))
    batch = update_many(*ins_predict_many(means, covs, ds, dth, dt, NOISE), rows, values, variances)
    for v in (0, 3, 6):
        alone = update_many(*ins_predict_many(means[v:v + 1], covs[v:v + 1], ds[v:v + 1], dth[v:v + 1],
                                              dt[v:v + 1], NOISE), rows, values[v:v + 1], variances[v:v + 1])
        np.testing.assert_array_equal(batch[0][v], alone[0][0])
        np.testing.assert_array_equal(batch[1][v], alone[1][0])


def test_a_non_positive_ins_interval_is_refused() -> None:
    means, covs = _states(np.random.default_rng(0), 2)
    with pytest.raises(ValueError, match="positive"):
        ins_predict_many(means, covs, np.ones(2), np.zeros(2), np.array([0.2, 0.0]), NOISE)


def test_gaussian_updates_equal_gaussian_update_for_every_kind_of_report() -> None:
    # the batched path reads what common_observations observes by itself (fleet_ekf._observed): it must agree
    from gcs.core.navigation.fleet_ekf import gaussian_updates
    from gcs.core.navigation.skf import NavGaussian, NavMeasurement, NavParams, gaussian_update

    params, rng = NavParams(), np.random.default_rng(11)
    means, covs = _states(rng, 6)
    stamp = 10**12
    estimates = [NavGaussian(stamp, means[v], covs[v]) for v in range(6)]
    ins = (5.0, 0.02, 0.2)
    measurements = [
        NavMeasurement(stamp + 2 * 10**8, ins, means[0, :2] + 3.0, 0.2, means[0, 3:5] + 0.5, 0.3),  # std below min
        NavMeasurement(stamp + 2 * 10**8, ins, means[1, :2] - 2.0, 2.0, None, None),
        NavMeasurement(stamp + 2 * 10**8, ins, None, None, None, None),  # INS only: prediction alone
        NavMeasurement(stamp + 2 * 10**8, ins, means[3, :2], 1.5, means[3, 3:5], -3.1),
        NavMeasurement(stamp + 5 * 10**8, ins, means[4, :2], 1.5, None, None),  # a gap: the one-at-a-time path
        NavMeasurement(stamp - 1, ins, None, None, None, None),  # older than the estimate: its own error
    ]
    results = gaussian_updates(params, estimates, measurements)
    for estimate, measurement, result in zip(estimates[:5], measurements[:5], results[:5]):
        expected = gaussian_update(params, estimate, measurement)
        assert result.stamp_ns == expected.stamp_ns
        _close(result.mean, expected.mean)
        _close(result.cov, expected.cov)
    assert isinstance(results[5], ValueError)
