"""Sensor model (wang2012 eq. 3-4): known geometry, Jacobian vs finite differences, seam handling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from gcs.core.models.sensor import SensorModel

RBE = SensorModel.range_bearing(10.0, 0.05, 0.05)
coords = st.floats(-3000.0, 3000.0)


def test_known_geometry() -> None:
    vehicle = np.array([0.0, 0.0, 300.0])
    z = RBE.measure(np.array([400.0, 0.0]), vehicle)
    np.testing.assert_allclose(z, [500.0, 0.0, -math.atan2(300.0, 400.0)])
    north = RBE.measure(np.array([0.0, 400.0]), vehicle)
    assert north[1] == pytest.approx(math.pi / 2)
    west = RBE.measure(np.array([-400.0, 0.0]), vehicle)
    assert west[1] == pytest.approx(math.pi)
    below = RBE.measure(np.array([1e-9, 0.0]), vehicle)
    assert below[2] == pytest.approx(-math.pi / 2)


def test_subsets_pick_their_components() -> None:
    vehicle = np.array([100.0, 50.0, 200.0])
    target = np.array([700.0, -250.0])
    full = RBE.measure(target, vehicle)
    np.testing.assert_allclose(SensorModel.bearing_only(0.01).measure(target, vehicle), full[1:2])
    np.testing.assert_allclose(SensorModel.bearing_only(0.01, 0.02).measure(target, vehicle), full[1:])
    with pytest.raises(ValueError, match="azimuth"):
        SensorModel(("range",), (1.0,))
    with pytest.raises(ValueError, match="ordered subset"):
        SensorModel(("azimuth", "range"), (1.0, 1.0))


@given(coords, coords, coords, coords, st.floats(50.0, 500.0))
def test_jacobian_matches_central_differences(tx: float, ty: float, vx: float, vy: float, vz: float) -> None:
    target = np.array([tx, ty, 3.0, -1.0])
    vehicle = np.array([vx, vy, vz])
    if math.hypot(tx - vx, ty - vy) < 1.0:
        return  # azimuth is singular straight below the vehicle
    analytic = RBE.jacobian(target, vehicle, state_dim=4)
    numeric = np.zeros_like(analytic)
    for j in range(4):
        step = np.zeros(4)
        step[j] = 1e-3
        diff = RBE.measure(target + step, vehicle) - RBE.measure(target - step, vehicle)
        diff[1] = (diff[1] + math.pi) % (2 * math.pi) - math.pi
        numeric[:, j] = diff / 2e-3
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-9)
    assert np.all(analytic[:, 2:] == 0.0)


def test_residual_is_seam_safe() -> None:
    z = np.array([100.0, math.pi - 0.01, -0.3])
    z_pred = np.array([90.0, -math.pi + 0.01, -0.3])
    np.testing.assert_allclose(RBE.residual(z, z_pred), [10.0, -0.02, 0.0], atol=1e-12)
    batch = RBE.residual(np.tile(z, (4, 1)), np.tile(z_pred, (4, 1)))
    np.testing.assert_allclose(batch[:, 1], -0.02, atol=1e-12)


def test_distance_dependent_noise_follows_zuo2021_eq2() -> None:
    sensor = SensorModel.bearing_only(math.radians(1.0), distance_dependent=True, reference_range_m=1500.0)
    near = sensor.noise_variance(None, np.array([1000.0, 0.0]), np.array([0.0, 0.0, 0.0]))
    far = sensor.noise_variance(None, np.array([6000.0, 0.0]), np.array([0.0, 0.0, 0.0]))
    assert near[0] == pytest.approx(math.radians(1.0) ** 2)
    assert far[0] == pytest.approx(math.radians(1.0) ** 2 * (6000.0 / 1500.0) ** 2)
    np.testing.assert_allclose(RBE.noise_information(), 1.0 / np.array([100.0, 0.0025, 0.0025]))


def test_distance_dependent_noise_without_a_range_names_what_it_needs() -> None:
    sensor = SensorModel.bearing_only(math.radians(1.0), distance_dependent=True)
    with pytest.raises(ValueError, match="needs the predicted range .* or target_xy and vehicle_xyz"):
        sensor.noise_variance(np.array([0.3]))
    with pytest.raises(ValueError, match="target_xy and vehicle_xyz"):
        sensor.noise_information(None, np.array([1000.0, 0.0]))


def _numeric_hessians(sensor: SensorModel, target: np.ndarray, vehicle: np.ndarray, step: float) -> np.ndarray:
    """Second derivatives of every component with respect to the target's (x, y), central differences: (m, 2, 2)."""
    def h(dx: float, dy: float) -> np.ndarray:
        z = sensor.measure(target + np.array([dx, dy]), vehicle)
        z[sensor.azimuth_index] = z[sensor.azimuth_index] - centre[sensor.azimuth_index]
        z[sensor.azimuth_index] = (z[sensor.azimuth_index] + math.pi) % (2 * math.pi) - math.pi
        return z

    centre = sensor.measure(target, vehicle)
    hess = np.empty((sensor.dim, 2, 2))
    hess[:, 0, 0] = (h(step, 0) - 2 * h(0, 0) + h(-step, 0)) / step**2
    hess[:, 1, 1] = (h(0, step) - 2 * h(0, 0) + h(0, -step)) / step**2
    hess[:, 0, 1] = hess[:, 1, 0] = (h(step, step) - h(step, -step) - h(-step, step) + h(-step, -step)) / (4 * step**2)
    return hess


@given(coords, coords, st.floats(-1500.0, 1500.0), st.floats(-1500.0, 1500.0), st.floats(50.0, 500.0),
       st.floats(1.0, 60.0), st.floats(1.0, 60.0), st.floats(-0.9, 0.9))
def test_linearisation_variance_is_half_the_trace_of_the_squared_hessian_times_p(
        tx: float, ty: float, ox: float, oy: float, vz: float, sx: float, sy: float, corr: float) -> None:
    """Oracle: ``1/2 tr((d^2 H_k P)^2)`` with the Hessian by central differences of ``measure``."""
    assume(math.hypot(ox, oy) > 20.0)
    target, vehicle = np.array([tx, ty]), np.array([tx - ox, ty - oy, vz])
    cov = np.array([[sx * sx, corr * sx * sy], [corr * sx * sy, sy * sy]])
    hess = _numeric_hessians(RBE, target, vehicle, step=1e-2 * math.hypot(ox, oy))
    expected = [0.5 * np.trace(hk @ cov @ hk @ cov) for hk in hess]
    np.testing.assert_allclose(RBE.linearisation_variance(target, vehicle, cov), expected, rtol=2e-3, atol=1e-14)


def test_linearisation_variance_matters_under_the_vehicle_only() -> None:
    """Against the azimuth's own noise (0.05 rad): negligible 300 m out, dominant 10 m out, for a 10 m prior."""
    cov = np.diag([100.0, 100.0])
    vehicle = np.array([0.0, 0.0, 200.0])
    far = RBE.linearisation_variance(np.array([300.0, 0.0]), vehicle, cov)
    near = RBE.linearisation_variance(np.array([10.0, 0.0]), vehicle, cov)
    noise = np.square(RBE.std)
    assert np.all(far < 0.01 * noise)
    assert near[RBE.azimuth_index] > 100 * noise[RBE.azimuth_index]
    assert near[RBE.azimuth_index] == pytest.approx(100.0**2 / 10.0**4)  # |P|^2 / rho_h^4 for an isotropic P
    right_above = RBE.linearisation_variance(np.array([0.0, 0.0]), vehicle, cov)
    assert np.all(np.isfinite(right_above)) and right_above[RBE.azimuth_index] > 1e6


def test_equal_models_hash_alike_and_the_scenarios_vehicles_share_one() -> None:
    import msgspec

    from gcs.engine.tracker_factory import filter_sensor_models
    from gcs.scenarios import load_scenario

    a, b = SensorModel.range_bearing(10.0, 0.05, 0.05), SensorModel.range_bearing(10.0, 0.05, 0.05)
    c = SensorModel.range_bearing(10.0, 0.05, 0.06)
    assert a == b and hash(a) == hash(b) and a != c and len({a, b, c}) == 2
    scenario = load_scenario("wang2012_urban")
    team = [msgspec.structs.replace(scenario.vehicles[0], id=f"uav{i}", sysid=i) for i in range(1, 11)]
    models = filter_sensor_models(msgspec.structs.replace(scenario, vehicles=team))
    assert len(models) == 10 and all(m is models[0] for m in models)  # one group, found without comparing


def test_a_model_from_another_process_hashes_as_this_process_hashes_it() -> None:
    import pickle

    model = SensorModel.range_bearing(10.0, 0.05, 0.05)
    hash(model)
    state = model.__getstate__()
    assert "_hash" not in state  # string hashes differ between processes: each hashes for itself
    copy = pickle.loads(pickle.dumps(model))
    assert copy == model and hash(copy) == hash(model)
    np.testing.assert_array_equal(copy.noise_variance(), model.noise_variance())
