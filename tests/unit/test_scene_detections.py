"""The many-target scan generator (sim_vehicles.truth.detections): counts, noise, field, occlusion, order."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.sensor import SensorModel
from sim_vehicles.truth.clutter import ground_disc_radius
from sim_vehicles.truth.detections import CLUTTER, scan
from sim_vehicles.truth.sensor import exact_measurements

SENSOR = SensorModel.range_bearing(5.0, 0.01, 0.02)
VEHICLES = np.array([[0.0, 0.0, 300.0], [400.0, 200.0, 250.0]])
TRUTHS = np.array([[100.0, 50.0], [300.0, -100.0], [-200.0, 150.0]])


def _many(draws: int, seed: int, **kw):
    rng = np.random.default_rng(seed)
    args = dict(pd=0.9, clutter_rate=2.0, max_range_m=1000.0) | kw
    return [scan(TRUTHS, VEHICLES, SENSOR, rng=rng, **args) for _ in range(draws)]


def test_detection_and_clutter_counts_match_pd_and_rate():
    draws = 1500
    scans = _many(draws, seed=11)
    hits = sum(int((s >= 0).sum()) for sc in scans for s in sc.sources)
    clutter = sum(int((s == CLUTTER).sum()) for sc in scans for s in sc.sources)
    trials = draws * len(VEHICLES) * len(TRUTHS)
    assert abs(hits - 0.9 * trials) < 4.0 * np.sqrt(trials * 0.9 * 0.1)  # binomial, 4 sigma
    mean_clutter = draws * len(VEHICLES) * 2.0
    assert abs(clutter - mean_clutter) < 4.0 * np.sqrt(mean_clutter)  # Poisson, 4 sigma
    # each truth is reported at most once per vehicle, with that vehicle's index and position
    for sc in scans[:50]:
        for v, (dets, src) in enumerate(zip(sc.detections, sc.sources)):
            real = src[src >= 0]
            assert len(set(real.tolist())) == len(real) and len(dets) == len(src)
            assert all(d.vehicle == v and np.array_equal(d.vehicle_xyz, VEHICLES[v]) for d in dets)


def test_noise_std_matches_the_sensor_model():
    scans = _many(3000, seed=12, pd=1.0, clutter_rate=0.0)
    exact = exact_measurements(np.column_stack([TRUTHS, np.zeros(3)]), VEHICLES[0])
    residuals = []
    for sc in scans:
        values = np.array([d.values for d in sc.detections[0]])
        residuals.append(values - exact[sc.sources[0]])
    residuals = np.concatenate(residuals)
    residuals[:, 1] = np.mod(residuals[:, 1] + np.pi, 2 * np.pi) - np.pi
    n = len(residuals)
    # sample std: relative standard error 1/sqrt(2n) (about 0.8 % here); 4 sigma; means within 4 sigma of 0
    assert np.abs(residuals.std(axis=0) / np.array(SENSOR.std) - 1.0).max() < 4.0 / np.sqrt(2 * n)
    assert np.all(np.abs(residuals.mean(axis=0)) < 4.0 * np.array(SENSOR.std) / np.sqrt(n))


def test_clutter_lies_in_the_ground_disc_of_the_field():
    scans = _many(400, seed=13, pd=0.0, clutter_rate=5.0, max_range_m=600.0)
    radius = ground_disc_radius(VEHICLES, 600.0, 0.0)
    assert np.all(radius > 0)
    for v in range(len(VEHICLES)):
        values = np.array([d.values for sc in scans for d in sc.detections[v]])
        assert np.all(np.concatenate([sc.sources[v] for sc in scans]) == CLUTTER)
        ground = values[:, 0] * np.cos(values[:, 2])  # horizontal distance from range and elevation
        assert ground.max() < radius[v] + 30.0 and ground.max() > 0.9 * radius[v]
        # uniform over the disc: half of the points inside radius / sqrt(2)
        inside = np.mean(ground < radius[v] / np.sqrt(2.0))
        assert abs(inside - 0.5) < 4.0 * np.sqrt(0.25 / len(ground))


def test_out_of_range_and_occluded_truths_are_never_detected():
    visible = np.ones((2, 3), dtype=bool)
    visible[1, 0] = False  # vehicle 1 cannot see truth 0
    scans = _many(200, seed=14, pd=1.0, clutter_rate=0.0, max_range_m=420.0, visible=visible)
    slant = np.hypot(np.linalg.norm(TRUTHS[None] - VEHICLES[:, None, :2], axis=-1), VEHICLES[:, None, 2])
    for v in range(2):
        expected = {j for j in range(3) if slant[v, j] <= 420.0 and visible[v, j]}
        assert expected and (slant[v] > 420.0).any()  # the scene leaves something to see and something beyond
        assert all(set(sc.sources[v].tolist()) == expected for sc in scans)
    assert 0 not in set(np.concatenate([sc.sources[1] for sc in scans]).tolist())


def test_order_is_random():
    scans = _many(200, seed=15, pd=1.0, clutter_rate=3.0)
    firsts = {int(sc.sources[0][0]) for sc in scans if len(sc.sources[0])}
    assert len(firsts) >= 3  # truths 0..2 and clutter all come first at times


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError):
        scan(TRUTHS, VEHICLES, SENSOR, 1.5, 1.0, 1000.0, np.random.default_rng(0))
    with pytest.raises(ValueError):
        scan(TRUTHS, VEHICLES, SENSOR, 0.9, 1.0, 1000.0, np.random.default_rng(0), visible=np.ones((3, 2), bool))
