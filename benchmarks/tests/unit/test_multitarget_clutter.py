"""The clutter density every method of the multitarget bench is given, against the simulator's own clutter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.multitarget import clutter_density_at
from gcs.core.models.sensor import SensorModel
from sim_vehicles.truth.detections import scan

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
VEHICLE = np.array([[0.0, 0.0, 200.0]])
MAX_RANGE_M, RATE = 5000.0, 1.0e6


def test_density_on_the_ground_surface_is_the_simulators() -> None:
    """Count the simulator's clutter measurements within 0.01 rad of the ground's elevation at their range, between
    900 and 1100 m: per unit volume that is the density at 1000 m, within Poisson noise (about 2500 counts)."""
    rng = np.random.default_rng(11)
    result = scan(np.zeros((0, 2)), VEHICLE, SENSOR, 0.9, RATE, MAX_RANGE_M, rng)
    z = np.array([d.values for d in result.detections[0]])
    rho, theta = z[:, 0], z[:, 2]
    ground_theta = -np.arcsin(200.0 / rho.clip(min=200.0))
    half_band, low, high = 0.01, 900.0, 1100.0
    inside = (rho >= low) & (rho <= high) & (np.abs(theta - ground_theta) <= half_band)
    volume = (high - low) * 2.0 * math.pi * 2.0 * half_band
    measured = inside.sum() / volume / (len(z) / RATE)  # per scan of RATE points
    # the band's average of the Gaussian over +-0.2 sigma is 0.9934 of its peak
    expected = clutter_density_at(1000.0, RATE, MAX_RANGE_M, 200.0, 0.05) * 0.9934
    assert measured == pytest.approx(expected, rel=0.08)
