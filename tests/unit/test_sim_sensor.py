"""Truth target sensor: components from the config, noise statistics, detection = line of sight & range."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gcs.config import SensorConfig
from gcs.core.world import RestrictedAirspace, World, generate_city
from sim_vehicles.truth.sensor import COMPONENTS, TargetSensor, exact_measurements

ALPHA = 1e-4
"""Two-sided false-alarm probability of every statistical check."""

TARGET = np.array([1200.0, 800.0, 0.0])


def _vehicles(rng: np.random.Generator, count: int, max_ground_m: float) -> np.ndarray:
    """Vehicles around TARGET: ground distance up to ``max_ground_m``, altitude 100-600 m."""
    distance = max_ground_m * np.sqrt(rng.random(count))
    angle = rng.uniform(-np.pi, np.pi, count)
    return np.stack([TARGET[0] + distance * np.cos(angle), TARGET[1] + distance * np.sin(angle),
                     rng.uniform(100.0, 600.0, count)], axis=1)


def _normalised_residuals(sensor: TargetSensor, seed: int, max_ground_m: float = 4000.0) -> np.ndarray:
    """Residuals of 3000 observations from random vehicles, each divided by ``std_at`` the true range."""
    rng = np.random.default_rng(seed)
    vehicles = _vehicles(rng, 3000, max_ground_m)
    obs = sensor.observe(TARGET, vehicles, None, rng)
    exact = exact_measurements(TARGET, vehicles)
    assert obs.components == sensor.components and obs.detected.all()
    residual = obs.values - exact[:, [COMPONENTS.index(c) for c in sensor.components]]
    a = sensor.components.index("azimuth")
    residual[:, a] = np.remainder(residual[:, a] + np.pi, 2 * np.pi) - np.pi
    return residual / sensor.std_at(exact[:, 0])


def _assert_standard_normal(normalised: np.ndarray) -> None:
    lo, hi = chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], len(normalised))
    statistic = np.sum(normalised**2, axis=0)  # one chi-square per component
    assert np.all((lo < statistic) & (statistic < hi)), (statistic, lo, hi)


@pytest.mark.parametrize(
    ("cfg", "components", "std"),
    [(SensorConfig(), ("range", "azimuth", "elevation"), (10.0, 0.05, 0.05)),
     (SensorConfig(kind="bearing_only", azimuth_std_rad=0.02, elevation_std_rad=0.03), ("azimuth", "elevation"),
      (0.02, 0.03)),
     (SensorConfig(kind="bearing_only", range_std_m=None, elevation_std_rad=None), ("azimuth",), (0.05,))],
)
def test_from_config_picks_components_and_std(cfg: SensorConfig, components: tuple, std: tuple) -> None:
    sensor = TargetSensor.from_config(cfg)
    assert (sensor.components, sensor.std, sensor.max_range_m) == (components, std, cfg.max_range_m)
    assert not sensor.distance_dependent
    far = TargetSensor.from_config(SensorConfig(noise="distance_dependent", reference_range_m=900.0))
    assert far.distance_dependent and far.reference_range_m == 900.0


def test_range_bearing_without_elevation_std_is_rejected() -> None:
    with pytest.raises(ValueError, match="elevation_std_rad"):
        TargetSensor.from_config(SensorConfig(elevation_std_rad=None))


def test_std_at_grows_beyond_the_reference_range_only() -> None:
    sensor = TargetSensor.from_config(SensorConfig(noise="distance_dependent", reference_range_m=1000.0))
    np.testing.assert_allclose(sensor.std_at([500.0, 1000.0, 3000.0]),
                               [[10.0, 0.05, 0.05], [10.0, 0.05, 0.05], [30.0, 0.15, 0.15]])
    np.testing.assert_allclose(sensor.std_at(2000.0), [20.0, 0.1, 0.1])  # a scalar range gives (m,)
    constant = TargetSensor.from_config(SensorConfig())
    np.testing.assert_allclose(constant.std_at(3000.0), [10.0, 0.05, 0.05])


def test_range_bearing_constant_noise_is_standard_normal_after_scaling() -> None:
    sensor = TargetSensor.from_config(SensorConfig(range_std_m=8.0, azimuth_std_rad=0.02, elevation_std_rad=0.01,
                                                   max_range_m=1e5))
    _assert_standard_normal(_normalised_residuals(sensor, seed=31))


def test_bearing_only_noise_is_standard_normal_after_scaling() -> None:
    sensor = TargetSensor.from_config(SensorConfig(kind="bearing_only", azimuth_std_rad=0.3, elevation_std_rad=0.02,
                                                   max_range_m=1e5))
    normalised = _normalised_residuals(sensor, seed=32)
    assert normalised.shape[1] == 2
    _assert_standard_normal(normalised)


def test_distance_dependent_noise_follows_zuo2021_eq2() -> None:
    cfg = SensorConfig(noise="distance_dependent", reference_range_m=1000.0, max_range_m=1e5)
    sensor = TargetSensor.from_config(cfg)
    normalised = _normalised_residuals(sensor, seed=33, max_ground_m=6000.0)
    _assert_standard_normal(normalised)
    # Judged against the constant sigma instead, the same residuals are far too wide: the scaling matters.
    rng = np.random.default_rng(33)
    scale = np.maximum(exact_measurements(TARGET, _vehicles(rng, 3000, 6000.0))[:, 0] / 1000.0, 1.0)
    hi = chi2.ppf(1 - ALPHA / 2, len(normalised))
    assert np.all(np.sum((normalised * scale[:, None]) ** 2, axis=0) > hi)


def test_detection_is_line_of_sight_and_range_in_a_small_city() -> None:
    buildings, streets = generate_city(np.random.default_rng(4), size_m=(1000.0, 1000.0), buildings=40,
                                       street_width_m=25.0, min_height_m=20.0, max_height_m=150.0)
    world = World(buildings, RestrictedAirspace.empty(), streets, (1000.0, 1000.0))
    sensor = TargetSensor.from_config(SensorConfig(max_range_m=600.0))
    rng = np.random.default_rng(34)
    target = np.array([streets.xs[2], streets.ys[1] + 10.0, 0.0])
    vehicles = np.column_stack([rng.uniform(0.0, 1000.0, (500, 2)), rng.uniform(30.0, 300.0, 500)])
    obs = sensor.observe(target, vehicles, world.line_of_sight, rng)
    in_range = np.linalg.norm(vehicles - target, axis=1) <= 600.0
    visible = world.line_of_sight(np.broadcast_to(target, vehicles.shape), vehicles)
    np.testing.assert_array_equal(obs.detected, visible & in_range)
    assert 0 < (visible & in_range).sum() and (~visible & in_range).sum() > 0 and (visible & ~in_range).sum() > 0
    assert np.isnan(obs.values[~obs.detected]).all() and np.isfinite(obs.values[obs.detected]).all()
