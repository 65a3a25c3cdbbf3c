"""The road tracker's parts against independent figures: the association terms against the Gaussian tracker's
costs, the mixture update against the PDA posterior written out hypothesis by hypothesis, the existence against
IPDA's closed form, systematic resampling's copies, new clouds on and off the road, and the merging rule."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.gnn import assignment_costs
from gcs.core.multitarget.road_association import costs_of, detection_probabilities, mixture_log_weights, \
    particle_terms
from gcs.core.multitarget.road_clouds import TrackClouds, start_clouds, systematic_rows
from gcs.core.multitarget.road_existence import existence_log_ratio, updated_existence
from gcs.core.multitarget.road_merging import merged, unresolved
from gcs.core.multitarget.tracks import Lifecycle, TrackSet
from gcs.core.roads import RoadGraph, RoadParticleFilter
from gcs.core.roads.particles import RoadParticles

SENSOR = SensorModel.range_bearing(10.0, 0.02, 0.02)
VEHICLE = np.array([[-300.0, -200.0, 200.0], [-300.0, -200.0, 200.0]])
CROSSROADS = RoadGraph.from_segments([(0.0, -600.0), (0.0, 0.0), (-600.0, 0.0), (0.0, 0.0)],
                                     [(0.0, 0.0), (0.0, 600.0), (0.0, 0.0), (600.0, 0.0)])


def _measure(xy: np.ndarray) -> np.ndarray:
    """Range, azimuth and elevation of ground points (n, 2) from VEHICLE[0], written out (not the filter's h)."""
    d = xy - VEHICLE[0, :2]
    horizontal = np.hypot(d[:, 0], d[:, 1])
    return np.stack([np.hypot(horizontal, 200.0), np.arctan2(d[:, 1], d[:, 0]), np.arctan2(-200.0, horizontal)], 1)


def test_a_cloud_at_one_point_costs_what_the_gaussian_tracker_s_pair_costs() -> None:
    """P particles at one point with P_D everywhere: ``a = P_D N(z; h(x), R)`` and ``m = 1 - P_D P_G``, the
    Gaussian tracker's cost with no prior covariance."""
    point = np.array([[40.0, 25.0]])
    z = _measure(np.array([[45.0, 20.0], [-10.0, 60.0]]))
    xy = np.broadcast_to(point, (1, 7, 2)).copy()
    log_w = np.full((1, 7), -np.log(7.0))
    pd = detection_probabilities(None, log_w.shape, 0.9, 0.02)
    terms = particle_terms(xy, log_w, pd, 0.99, (SENSOR, z, VEHICLE, None), 0.0)
    inn = batched.innovations(np.array([[40.0, 25.0, 0.0, 0.0]]), np.zeros((1, 4, 4)), SENSOR, z, VEHICLE,
                              np.zeros((2, 3, 3)))
    valid = np.ones((1, 2), dtype=bool)
    expected = assignment_costs(inn.log_likelihood, valid, 0.9, 0.99, 1e-5)
    assert costs_of(terms, valid, 1e-5) == pytest.approx(expected, rel=1e-9)


def test_the_mixture_update_is_the_pda_posterior_hypothesis_by_hypothesis() -> None:
    rng = np.random.default_rng(1)
    xy = rng.normal(30.0, 15.0, (2, 5, 2))
    log_w = np.log(rng.dirichlet(np.ones(5), size=2))
    seen = rng.random((2, 5)) < 0.6
    pd = detection_probabilities(seen, seen.shape, 0.9, 0.02)
    z = _measure(np.array([[35.0, 20.0], [10.0, 50.0]]))
    terms = particle_terms(xy, log_w, pd, 0.99, (SENSOR, z, VEHICLE, None), 4.0)
    beta = np.array([[0.5, 0.2], [0.1, 0.6]])
    got = np.exp(mixture_log_weights(terms, beta))
    for t in range(2):
        w = np.exp(log_w[t])
        missed = w * (1.0 - pd[t] * 0.99)
        posterior = (1.0 - beta[t].sum()) * missed / missed.sum()
        for j in range(2):
            like = np.array([_gaussian(z[j], xy[t, i], 4.0) for i in range(5)])
            hypothesis = w * pd[t] * like
            posterior = posterior + beta[t, j] * hypothesis / hypothesis.sum()
        assert got[t] == pytest.approx(posterior, rel=1e-9)
        assert got[t].sum() == pytest.approx(1.0)


def _gaussian(z: np.ndarray, xy: np.ndarray, spread_var: float) -> float:
    """N(z; h(x), R) with R the sensor's noise plus the spread seen from the vehicle (range, azimuth, elevation)."""
    h = _measure(xy[None])[0]
    d = xy - VEHICLE[0, :2]
    horizontal2 = d @ d
    rho2 = horizontal2 + 200.0**2
    var = np.array(SENSOR.std) ** 2 + spread_var * np.array([1.0, 1.0 / horizontal2, 1.0 / rho2])
    nu = z - h
    nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
    return float(np.exp(-0.5 * np.sum(nu * nu / var)) / np.sqrt(np.prod(2 * np.pi * var)))


def test_existence_follows_ipda_s_closed_form() -> None:
    """IPDA (Musicki et al. 1994) for a point cloud: ``delta = P_D P_G - P_D sum_j N_j / lambda``,
    ``r = (1 - delta) r^- / (1 - delta r^-)``; with nothing detected ``r = (1 - P_D P_G) r^- / (1 - P_D P_G r^-)``."""
    xy = np.zeros((1, 3, 2)) + 40.0
    log_w = np.full((1, 3), -np.log(3.0))
    pd = detection_probabilities(None, log_w.shape, 0.9, 0.02)
    z = _measure(np.array([[45.0, 38.0]]))
    terms = particle_terms(xy, log_w, pd, 0.99, (SENSOR, z, VEHICLE[:1], None), 0.0)
    density = 1e-3
    normal = _gaussian(z[0], xy[0, 0], 0.0)
    for counted, delta in ((np.array([[True]]), 0.9 * 0.99 - 0.9 * normal / density),
                           (np.array([[False]]), 0.9 * 0.99)):
        r = updated_existence(np.array([0.6]), existence_log_ratio(terms, counted, density))
        assert r[0] == pytest.approx((1.0 - delta) * 0.6 / (1.0 - delta * 0.6), rel=1e-9)


def test_systematic_resampling_copies_each_particle_floor_or_ceil_of_p_w_times() -> None:
    rng = np.random.default_rng(2)
    weights = rng.dirichlet(np.full(40, 0.3), size=6)
    picked = systematic_rows(weights, rng)
    for row in range(6):
        copies = np.bincount(picked[row], minlength=40)
        assert np.all(copies >= np.floor(40 * weights[row]) - 1e-9) and np.all(copies <= np.ceil(40 * weights[row]))


def test_new_clouds_are_on_the_nearest_road_and_off_it_far_from_every_road() -> None:
    """A detection 5 m off the east arm starts a cloud on it (but the share ``initial_off_road``); one 300 m from
    every road starts a cloud that is all off the road, where it was drawn."""
    motion = RoadParticleFilter(CROSSROADS)
    mean = np.array([[200.0, 5.0, 0.0, 0.0], [300.0, 300.0, 0.0, 0.0]])
    cov = np.tile(np.diag([9.0, 9.0, 25.0, 25.0]), (2, 1, 1))
    clouds = start_clouds(motion, mean, cov, 400, 3.0, 0.5, np.random.default_rng(3))
    on_road = clouds.rows("on_road")
    assert on_road[0].mean() == pytest.approx(1.0 - motion.initial_off_road, abs=0.04)
    assert np.all(np.abs(clouds.rows("xy")[0][on_road[0], 1]) < 1e-9)  # on the centre line (the offset apart)
    assert not on_road[1].any() and np.linalg.norm(clouds.rows("xy")[1].mean(axis=0) - (300.0, 300.0)) < 1.0
    assert clouds.existence.tolist() == [0.5, 0.5] and clouds.tracks == 2


def _tracks(ids, xy, status=Lifecycle.CONFIRMED) -> TrackSet:
    k = len(ids)
    mean = np.zeros((k, 4))
    mean[:, :2] = xy
    cov = np.tile(np.diag([25.0, 25.0, 4.0, 4.0]), (k, 1, 1))
    return TrackSet(np.array(ids), mean, cov, np.full(k, status), np.ones(k), np.ones(k), np.zeros(k))


def test_tracks_driving_one_street_one_way_close_together_are_unresolved_and_the_younger_is_merged() -> None:
    """Tracks 1 and 2 on the eastbound edge 5 m apart: unresolved. Track 3 on the northbound edge at the same
    point and track 4 on the westbound edge (the same street the other way) are not. Track 2 is dropped on the
    third unresolved scan in a row, not before; track 1, the older, never."""
    east = int(np.flatnonzero((CROSSROADS.direction[:, 0] > 0.99) & (CROSSROADS.nodes[CROSSROADS.tail, 0] >= 0.0))[0])
    north = int(np.flatnonzero((CROSSROADS.direction[:, 1] > 0.99) & (CROSSROADS.nodes[CROSSROADS.tail, 1] >= 0.0))[0])
    west = int(CROSSROADS.reverse[east])
    p = 50
    edges = np.repeat([east, east, north, west], p)
    s = np.concatenate([np.full(p, 100.0), np.full(p, 105.0), np.full(p, 100.0),
                        CROSSROADS.length[west] - np.full(p, 100.0)])
    cloud = RoadParticles.build(CROSSROADS, edges, s, np.full(4 * p, 10.0), np.ones(4 * p, dtype=bool),
                                np.zeros((4 * p, 2)), np.zeros((4 * p, 2)), np.full(4 * p, -np.log(p)))
    clouds = TrackClouds(cloud, np.zeros(4 * p), np.ones(4), np.zeros(4, dtype=np.int64), p)
    tracks = _tracks([1, 2, 3, 4], clouds.summary(CROSSROADS)[0][:, :2])
    pairs = unresolved(clouds, tracks.mean, tracks.cov, len(CROSSROADS), 0.5, 9.21)
    assert pairs[0, 1] and pairs[1, 0]
    assert not pairs[0, 2] and not pairs[0, 3] and not pairs[1, 2] and not pairs[2, 3]
    counts = np.zeros(4, dtype=np.int64)
    for scan in range(3):
        drop, counts = merged(tracks, pairs, counts, 3)
        assert drop.tolist() == [False, scan == 2, False, False]
    drop, counts = merged(tracks, np.zeros_like(pairs), counts, 3)  # resolved once: the count starts again
    assert counts.tolist() == [0, 0, 0, 0] and not drop.any()
