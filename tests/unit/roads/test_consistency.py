"""Both road trackers on a straight road: NEES over Monte Carlo runs, bearing-only fusion, a car that leaves
the road into a square, and the per-detection likelihood the many-target tracker associates with."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gcs.core.filters.estimate import GaussianEstimate, ns_from_s
from gcs.core.roads import RoadGraph
from tests.unit.roads._scenes import BEARINGS, SENSOR, TRACKERS, detections

ROAD = RoadGraph.from_segments([(-2000.0, 0.0)], [(2000.0, 0.0)])
UAVS = np.array([[-900.0, 300.0, 200.0], [-700.0, -400.0, 220.0], [-500.0, 200.0, 240.0]])
P0 = np.diag([400.0, 400.0, 9.0, 9.0])


def _drive(name: str, run: int, steps: int, sensor=SENSOR, offset_m: float = 0.0):
    """A car driving the trackers' own road model (white-noise acceleration along the road of density
    ``speed_psd_m2_s3``, sampled exactly; seen as a point ``spread_m`` about the road, isotropic) and every
    step's estimate; the track starts from a draw of N(truth, P0) with covariance P0, moved ``offset_m`` east."""
    rng, filter_rng = np.random.default_rng([run, 7]), np.random.default_rng([run, 8])
    tracker = TRACKERS[name](ROAD)
    q = tracker.speed_psd_m2_s3
    s, v = -1000.0, 10.0
    truths, estimates, estimate = [], [], None
    for k in range(steps):
        if k:
            w = rng.multivariate_normal([0.0, 0.0], q * np.array([[1.0 / 3.0, 0.5], [0.5, 1.0]]))
            s, v = s + v + w[0], v + w[1]
        seen_at = np.array([s, 0.0]) + tracker.spread_m * rng.standard_normal(2)
        groups = detections(seen_at, UAVS, sensor, rng)
        if estimate is None:
            mean = rng.multivariate_normal([s, 0.0, v, 0.0], P0) + [offset_m, 0.0, 0.0, 0.0]
            start = tracker.start(GaussianEstimate(mean, P0, 0), filter_rng)
            estimate = tracker.update(start, groups, None, filter_rng)
        else:
            estimate = tracker.step(estimate, ns_from_s(float(k)), groups, None, filter_rng)
        truths.append(s)
        estimates.append(estimate)
    return tracker, np.array(truths), estimates


@pytest.mark.slow
@pytest.mark.parametrize("name", TRACKERS)
def test_along_road_nees_is_inside_its_chi_square_band(name: str) -> None:
    """The along-road error's NEES ``e^2 / P_xx`` (1 degree of freedom) averaged over M = 50 runs and steps 5-29.

    The band is that of chi2(M) / M at 99%: the steps of one run are correlated, and treating each run's
    time average as one chi2(1) draw (full correlation) gives the widest, so a safe, band. Recorded on one
    machine: 0.99 (mixture) and 0.89 (particles, 2000 of them), against [0.56, 1.59].
    """
    runs, steps = 50, 30
    nees = np.zeros((runs, steps))
    for run in range(runs):
        _, truth, estimates = _drive(name, run, steps)
        nees[run] = [(e.mean[0] - t) ** 2 / e.cov[0, 0] for e, t in zip(estimates, truth)]
    low, high = chi2.ppf([0.005, 0.995], runs) / runs
    assert low <= nees[:, 5:].mean() <= high
    per_step = nees[:, 5:].mean(axis=0)
    # each step's run average inside the same band in at least 85% of the 25 steps (1% expected outside each)
    assert np.mean((per_step >= low) & (per_step <= high)) >= 0.85


@pytest.mark.parametrize("name", TRACKERS)
def test_bearing_only_sensors_are_fused(name: str) -> None:
    tracker, truth, estimates = _drive(name, 3, 25, sensor=BEARINGS, offset_m=60.0)
    errors = np.array([abs(e.mean[0] - t) for e, t in zip(estimates, truth)])
    # the track starts 60 m (3 sigma of P0) off; three bearings of 0.02 rad from 300-800 m cross within about
    # 10 m, so after ten steps the error stays below 15 m and the filter's own sigma below 10 m
    assert errors[10:].max() < 15.0
    assert np.sqrt(estimates[-1].cov[0, 0]) < 10.0


@pytest.mark.parametrize("name", TRACKERS)
def test_a_car_that_leaves_the_road_into_a_square_is_followed(name: str) -> None:
    rng, filter_rng = np.random.default_rng(21), np.random.default_rng(22)
    tracker = TRACKERS[name](ROAD)
    uavs = np.array([[-300.0, 300.0, 200.0], [100.0, -300.0, 220.0], [200.0, 300.0, 240.0]])
    position, estimate = np.array([-300.0, 0.0]), None
    for k in range(40):  # 20 s east along the road at 10 m/s, then 20 s north into the square at 8 m/s
        position = position + (np.array([10.0, 0.0]) if k <= 20 else np.array([0.0, 8.0])) * (k > 0)
        groups = detections(position, uavs, SENSOR, rng)
        if estimate is None:
            first = GaussianEstimate(np.array([-300.0, 0.0, 10.0, 0.0]), P0, 0)
            estimate = tracker.update(tracker.start(first, filter_rng), groups, None, filter_rng)
        else:
            estimate = tracker.step(estimate, ns_from_s(float(k)), groups, None, filter_rng)
    assert position[1] == pytest.approx(152.0)
    assert estimate.off_road_probability > 0.5
    # the detections fix the car to about 10 m (three range-bearing sensors at 300-400 m)
    assert np.hypot(*(estimate.mean[:2] - position)) < 20.0


def test_per_detection_likelihoods_of_both_trackers_agree() -> None:
    """``log_likelihood`` of a detection at the car and of one 60 m along the road from it: the particle sum and
    the mixture's Gaussian are two computations of one predictive density; they agree within 0.5 nat (the
    particles' Monte Carlo error and the mixture's linearisation), and both rank the near detection first."""
    scores = {}
    for name in TRACKERS:
        tracker, truth, estimates = _drive(name, 5, 15)
        rng = np.random.default_rng(30)
        prior = tracker.predict(estimates[-1], ns_from_s(15.0), rng)
        ahead = truth[-1] + 10.0
        near = detections((ahead, 0.0), UAVS[:1], SENSOR, np.random.default_rng(31))[0]
        far = detections((ahead + 60.0, 0.0), UAVS[:1], SENSOR, np.random.default_rng(31))[0]
        scores[name] = np.array([tracker.log_likelihood(prior, near)[0], tracker.log_likelihood(prior, far)[0]])
    assert scores["particle"] == pytest.approx(scores["mixture"], abs=0.5)
    for near, far in scores.values():
        assert near > far + 3.0
