"""The compiled DUIF update gives the numpy form's numbers, for every sensor and vehicle-error form it takes.

The two compute the same sums in another order (scalars in the kernel, stacked arrays in
numpy) and symmetrise the information once more or less: they differ by rounding,
about 1e-13 relative. The bound below, 1e-9 relative (plus 1e-9 absolute, for the
entries that are zero but for rounding), is far above that and far below any
mistake in a formula, which moves the posterior by a tenth of a metre or more.
"""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.estimate import CA2D, GaussianEstimate, NotPositiveDefinite
from gcs.core.filters.iterated import MAX_RELINEARISATIONS, iterated_update, iterated_update_many, kernel_available
from gcs.core.filters.uif import UnscentedInformationFilter
from gcs.core.models.motion import constant_acceleration, constant_velocity
from gcs.core.models.sensor import SensorModel

RTOL = ATOL = 1e-9
RANGE_BEARING = SensorModel.range_bearing(10.0, 0.05, 0.05)
SENSORS = {
    "range-bearing": RANGE_BEARING,
    "bearing-only": SensorModel.bearing_only(0.02),
    "bearings, elevation": SensorModel.bearing_only(0.02, 0.03, target_height_m=1.5),
    "distance-dependent range-bearing": SensorModel.range_bearing(5.0, 0.01, 0.01, distance_dependent=True,
                                                                  reference_range_m=200.0),
    "distance-dependent bearings": SensorModel.bearing_only(0.01, 0.01, distance_dependent=True,
                                                            reference_range_m=200.0),
}


def _case(seed: int, sensor: SensorModel, vehicles: int, prior_std_m: float, vehicle_var: bool
          ) -> tuple[GaussianEstimate, list]:
    """A prior around a target, and the target's noise-free measurements from vehicles 100-600 m out."""
    rng = np.random.default_rng(seed)
    truth = np.array([1000.0, -400.0])
    mean = np.concatenate([truth + rng.normal(0.0, prior_std_m, 2), rng.normal(0.0, 3.0, 2)])
    root = rng.normal(0.0, 1.0, (4, 4)) * [prior_std_m, prior_std_m, 2.0, 2.0]
    prior = GaussianEstimate(mean, root @ root.T + np.diag([prior_std_m**2, prior_std_m**2, 4.0, 4.0]), 10**9)
    angles = rng.uniform(-np.pi, np.pi, vehicles)
    distances = rng.uniform(100.0, 600.0, vehicles)
    xyz = np.column_stack([truth[0] + distances * np.cos(angles), truth[1] + distances * np.sin(angles),
                           rng.uniform(150.0, 300.0, vehicles)])
    z = sensor.measure(truth, xyz)
    covs = rng.uniform(0.0, 25.0, vehicles) if vehicle_var else None
    return prior, [(sensor, z, xyz, covs)]


def _same(compiled: GaussianEstimate, numpy_form: GaussianEstimate) -> None:
    np.testing.assert_allclose(compiled.mean, numpy_form.mean, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(compiled.cov, numpy_form.cov, rtol=RTOL, atol=ATOL)
    assert compiled.stamp_ns == numpy_form.stamp_ns and compiled.layout is numpy_form.layout


def test_the_kernel_is_there_to_compare() -> None:
    assert kernel_available()  # numba is in the test extra: the comparisons below run both forms


@pytest.mark.parametrize("name", list(SENSORS))
@pytest.mark.parametrize("second_order", [True, False])
@pytest.mark.parametrize("vehicle_var", [False, True])
def test_the_kernel_gives_the_numpy_forms_numbers(name: str, second_order: bool, vehicle_var: bool) -> None:
    uif = UnscentedInformationFilter(constant_velocity(1.96), second_order=second_order)
    for seed in range(6):
        prior, stacked = _case(seed, SENSORS[name], 1 + seed % 4, 5.0 + 40.0 * (seed % 3), vehicle_var)
        _same(iterated_update(uif, prior, stacked), iterated_update(uif, prior, stacked, compiled=False))


def test_a_wide_wrong_prior_is_relinearised_alike() -> None:
    """A prior 300 m off and 300 m wide: one linearisation stops short, and both forms iterate."""
    uif = UnscentedInformationFilter(constant_velocity(1.96))
    prior, stacked = _case(3, RANGE_BEARING, 3, 300.0, False)
    compiled = iterated_update(uif, prior, stacked)
    _same(compiled, iterated_update(uif, prior, stacked, compiled=False))
    once = uif.update(uif.contribution(prior, *stacked[0][:3]))
    truth = np.array([1000.0, -400.0])
    assert np.linalg.norm(compiled.mean[:2] - truth) < 0.5 * np.linalg.norm(once.mean[:2] - truth)
    assert MAX_RELINEARISATIONS >= 1


def test_several_sensor_groups_and_a_vehicle_right_above_the_target() -> None:
    uif = UnscentedInformationFilter(constant_velocity(1.96))
    prior, ranged = _case(7, RANGE_BEARING, 2, 20.0, True)
    _, bearings = _case(8, SENSORS["bearings, elevation"], 3, 20.0, False)
    above = (RANGE_BEARING, RANGE_BEARING.measure(np.array([1000.0, -400.0]), np.array([[1000.0, -400.0, 200.0]])),
             np.array([[1000.0, -400.0, 200.0]]), np.array([4.0]))
    stacked = ranged + bearings + [above]
    _same(iterated_update(uif, prior, stacked), iterated_update(uif, prior, stacked, compiled=False))


def test_a_six_state_prior_and_one_measurement_without_a_leading_axis() -> None:
    uif = UnscentedInformationFilter(constant_acceleration(0.5))
    prior = GaussianEstimate(np.array([990.0, -390.0, 2.0, 1.0, 0.1, 0.0]), np.diag([100.0, 80.0, 4, 4, 1, 1]), 0,
                             layout=CA2D)
    xyz = np.array([1200.0, -300.0, 220.0])
    stacked = [(RANGE_BEARING, RANGE_BEARING.measure(np.array([1000.0, -400.0]), xyz), xyz, None)]
    _same(iterated_update(uif, prior, stacked), iterated_update(uif, prior, stacked, compiled=False))


def test_full_vehicle_covariances_take_the_numpy_form() -> None:
    uif = UnscentedInformationFilter(constant_velocity(1.96))
    prior, [(sensor, z, xyz, _)] = _case(4, RANGE_BEARING, 3, 20.0, False)
    covs = np.stack([np.diag([4.0, 9.0, 1.0])] * 3)
    stacked = [(sensor, z, xyz, covs)]
    assert iterated_update(uif, prior, stacked).mean.tolist() == \
        iterated_update(uif, prior, stacked, compiled=False).mean.tolist()


def test_the_kernel_refuses_what_the_numpy_form_refuses() -> None:
    uif = UnscentedInformationFilter(constant_velocity(1.96))
    prior, [(sensor, z, xyz, _)] = _case(5, RANGE_BEARING, 3, 20.0, False)
    for compiled in (True, False):
        with pytest.raises(ValueError, match=r"z must have shape \(\.\.\., 3\)"):
            iterated_update(uif, prior, [(sensor, z[:, :2], xyz, None)], compiled)
        with pytest.raises(ValueError, match="vehicle_cov must have shape"):
            iterated_update(uif, prior, [(sensor, z, xyz, np.ones(2))], compiled)
        flat = GaussianEstimate(prior.mean, np.diag([0.0, 1.0, 1.0, 1.0]), prior.stamp_ns)
        with pytest.raises(NotPositiveDefinite):
            iterated_update(uif, flat, [(sensor, z, xyz, None)], compiled)
    assert iterated_update(uif, prior, []) is prior


@pytest.mark.parametrize("compiled", [True, False])
def test_many_targets_in_one_call_are_each_updated_as_alone(compiled: bool) -> None:
    """Eight targets, one of them with a prior 300 m off (relinearised), the others near: one call."""
    uif = UnscentedInformationFilter(constant_velocity(1.96))
    cases = [_case(20 + t, RANGE_BEARING, 3, 300.0 if t == 2 else 10.0, False) for t in range(8)]
    means = np.stack([prior.mean for prior, _ in cases])
    covs = np.stack([prior.cov for prior, _ in cases])
    z = np.stack([stacked[0][1] for _, stacked in cases])
    xyz = np.stack([stacked[0][2] for _, stacked in cases])
    got_means, got_covs = iterated_update_many(uif, means, covs, RANGE_BEARING, z, xyz, compiled)
    for t, (prior, stacked) in enumerate(cases):
        alone = iterated_update(uif, prior, stacked, compiled=False)
        np.testing.assert_allclose(got_means[t], alone.mean, rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(got_covs[t], alone.cov, rtol=RTOL, atol=ATOL)
    with pytest.raises(ValueError, match=r"z \(T, k, 3\)"):
        iterated_update_many(uif, means, covs, RANGE_BEARING, z[:, :, :2], xyz, compiled)
