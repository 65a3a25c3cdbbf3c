"""One tracker interface: the single-target and the multi-target tracker both run as a
:class:`~gcs.core.target_tracker.TargetTracker`, driven here by one function that knows nothing else of them.

The figures are checked against the simulated truth (detections made by the tests' own formulas,
``tests/unit/multitarget/_scenes.py``), and the single-target scan against :func:`gcs.core.tracker.fuse`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import MultiTargetTracker
from gcs.core.single_target import SingleTargetTracker
from gcs.core.target_tracker import TargetTracker
from gcs.core.tracker import fuse
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario
from tests.unit.multitarget._scenes import cv_truth, scan_detections

S = 1_000_000_000
STEPS = 20
VEHICLES = np.array([[600.0, 700.0, 200.0], [1500.0, 600.0, 210.0], [1000.0, 1500.0, 220.0]])
STD = np.array([10.0, 0.05, 0.05])
"""The sensor noise of wang2012_urban (range m, azimuth and elevation rad)."""
CONFIG = tracker_config(load_scenario("wang2012_urban"), None, "ga_k5")


def run(tracker: TargetTracker, scans: Sequence[list], sensors: Sequence[SensorModel]):
    """Every scan through ``tracker``, one a second from 1 s; the last state and each scan's diagnostics."""
    state, diagnostics = tracker.start(), []
    for k, by_vehicle in enumerate(scans, start=1):
        state, scanned = tracker.scan(state, k * S, dict(enumerate(by_vehicle)), sensors)
        diagnostics.append(scanned)
    return state, diagnostics


def _scene(seed: int):
    rng = np.random.default_rng(seed)
    truth = cv_truth(rng, np.array([[1000.0, 1000.0, 5.0, 2.0]]), STEPS, 1.0, 0.05)
    scans = [scan_detections(rng, truth[k, :, :2], VEHICLES, STD) for k in range(STEPS)]
    return truth[-1, 0], scans


def test_both_trackers_follow_the_target_through_the_same_interface() -> None:
    target, scans = _scene(seed=7)
    estimate, scanned = run(SingleTargetTracker(CONFIG), scans, CONFIG.sensors)
    assert [len(s.detections) for s in scanned] == [3] * STEPS  # one detection of each vehicle, every scan
    # Three vehicles 400-700 m away, 10 m in range and 0.05 rad (20-35 m) across: after 20 scans the filter's own
    # position sigma (sqrt of the trace) is about 8 m; 25 m is three of them.
    assert np.linalg.norm(estimate.mean[:2] - target[:2]) < 25.0
    multi = MultiTargetTracker(motion=constant_velocity(0.05), detection_probability=0.99, clutter_density=1e-9)
    tracks, diagnostics = run(multi, scans, CONFIG.sensors)  # track 1, seen by every vehicle on the last scan
    confirmed = tracks.tracks.confirmed()
    assert confirmed.size == 1 and diagnostics[-1].detected_by == {0: (1,), 1: (1,), 2: (1,)}
    assert np.linalg.norm(confirmed.mean[0, :2] - target[:2]) < 25.0


def test_a_single_target_scan_fuses_what_fuse_fuses_bit_for_bit() -> None:
    _, scans = _scene(seed=3)
    tracker = SingleTargetTracker(CONFIG)
    estimate = by_interface = None
    for k, by_vehicle in enumerate(scans[:5], start=1):
        estimate = fuse(CONFIG, estimate, k * S, [found[0] for found in by_vehicle])
        by_interface, _ = tracker.scan(by_interface, k * S, dict(enumerate(by_vehicle)), CONFIG.sensors)
        assert np.array_equal(by_interface.mean, estimate.mean) and np.array_equal(by_interface.cov, estimate.cov)
