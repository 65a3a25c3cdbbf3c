"""The snake experiment's truth and data (feng2019 section 4) are what the benchmark says they are."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.skf import AMPLITUDE_M, GPS, HEADING_RAD, SPEED_MPS, generate_dataset, snake_truth
from gcs.core.geometry import wrap_angle


def test_snake_truth_is_self_consistent() -> None:
    t = np.arange(0.0, 120.0, 0.01)
    s = snake_truth(t)
    velocity = np.gradient(s[:, :2], t, axis=0)
    inner = (np.abs(t - 40.0) > 0.05) & (np.abs(t - 90.0) > 0.05)
    np.testing.assert_allclose(velocity[inner][1:-1], s[inner, 3:5][1:-1], atol=0.05)
    np.testing.assert_allclose(np.arctan2(s[:, 4], s[:, 3]), s[:, 2], atol=1e-12)
    rate = wrap_angle(np.diff(s[:, 2])) / 0.01
    np.testing.assert_allclose(rate[inner[1:]][1:-1], s[1:, 5][inner[1:]][1:-1], atol=2e-3)
    normal = np.array([-math.sin(HEADING_RAD), math.cos(HEADING_RAD)])
    lateral = (s[:, :2] - s[0, :2]) @ normal
    assert abs(lateral[t < 40.0]).max() < 1e-9  # straight on 25 deg azimuth first
    assert abs(lateral[(t >= 40.0) & (t <= 90.0)].max() - AMPLITUDE_M) < 1.0  # the 600 m snake
    np.testing.assert_allclose(np.hypot(s[t < 40.0, 3], s[t < 40.0, 4]), SPEED_MPS)
    assert np.ptp(s[t > 90.01, 2]) < 1e-12  # straight again after 90 s


def test_generated_data_come_from_the_simulator_models() -> None:
    data = generate_dataset(3, seed=1)
    again = generate_dataset(2, seed=1)
    np.testing.assert_array_equal(data.ins[:2], again.ins)  # run r is the same in any batch
    truth = data.truth
    path = np.hypot(*np.diff(truth[:, :2], axis=0).T)
    distance = data.ins[..., 0]
    assert abs(distance.sum(axis=1) / path.sum() - 1.01).max() < 0.002  # INS 1% scale error
    gps_error = data.gps_xy - truth[None, 1:, :2]
    assert 25.0 < gps_error.std() < 35.0 and np.all(data.gps_std_m == GPS.horizontal_std_m)
    outage = generate_dataset(1, seed=1, gps_outage_s=(50.0, 100.0))
    assert np.isnan(outage.gps_xy[0, 49:99]).all() and np.isfinite(outage.gps_xy[0, 99:]).all()
