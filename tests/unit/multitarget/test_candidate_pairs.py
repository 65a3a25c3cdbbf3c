"""The azimuth pre-gate leaves out no pair the chi-square gate takes, and a track's work does not grow with the
number of other tracks (pairs counted, not timed)."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.candidates import candidate_pairs
from gcs.core.multitarget.gating import gate, gate_threshold
from gcs.core.multitarget.tracker import MultiTargetState, MultiTargetTracker
from gcs.core.multitarget.tracks import TrackSet
from gcs.core.tracker import Detection

from ._cases import SENSORS, random_tracks, random_vehicle

DISTANCE_DEPENDENT = SensorModel.range_bearing(5.0, 0.01, 0.01, distance_dependent=True, reference_range_m=500.0)


def _gated_both_ways(mean, cov, sensor, z, xyz, pcov, probability=0.99):
    full = batched.innovations(mean, cov, sensor, z, xyz, pcov)
    pairs = candidate_pairs(mean, cov, sensor, z, xyz, pcov, gate_threshold(probability, sensor.dim))
    pruned = batched.innovations(mean, cov, sensor, z, xyz, pcov, pairs)
    return full, pruned, gate(full.d2, probability, sensor.dim), gate(pruned.d2, probability, sensor.dim)


@pytest.mark.parametrize("seed", range(12))
def test_no_pair_inside_the_gate_is_left_out(seed: int) -> None:
    rng = np.random.default_rng(seed)
    mean, cov = random_tracks(rng, 30)
    sensor = (*SENSORS, DISTANCE_DEPENDENT)[seed % 5]
    cov[:, :2, :2] *= 1.0 + 20.0 * (seed % 3)  # up to tracks hundreds of metres wide: wide windows
    sensor, z, xyz, pcov = random_vehicle(rng, sensor, mean[:20, :2], 15, uncertain=seed % 2 == 0)
    full, pruned, valid_full, valid_pruned = _gated_both_ways(mean, cov, sensor, z, xyz, pcov)
    assert valid_full.sum() >= 10  # the gate takes pairs; the comparison is not vacuous
    np.testing.assert_array_equal(valid_pruned, valid_full)
    np.testing.assert_array_equal(pruned.d2[valid_full], full.d2[valid_full])
    np.testing.assert_array_equal(pruned.s_inv[valid_full], full.s_inv[valid_full])
    assert pruned.pairs < full.pairs == mean.shape[0] * z.shape[0]


def test_tracks_across_the_seam_and_several_vehicle_positions_in_one_batch() -> None:
    rng = np.random.default_rng(5)
    angles = np.pi + rng.normal(0.0, 0.01, 12)  # around the +-pi seam, seen from the origin
    mean = np.column_stack([800.0 * np.cos(angles), 800.0 * np.sin(angles), np.zeros((12, 2))])
    cov = np.tile(np.diag([400.0, 400.0, 4.0, 4.0]), (12, 1, 1))
    sensor = SENSORS[0]
    here, there = np.array([0.0, 0.0, 200.0]), np.array([-1500.0, 300.0, 250.0])
    xyz = np.array([here] * 6 + [there] * 6)
    z = sensor.measure(mean[:12, :2] + rng.normal(0.0, 5.0, (12, 2)), xyz)
    pcov = np.zeros((12, 3, 3))
    full, pruned, valid_full, valid_pruned = _gated_both_ways(mean, cov, sensor, z, xyz, pcov)
    assert valid_full[:, :6].any() and valid_full[:, 6:].any()
    np.testing.assert_array_equal(valid_pruned, valid_full)


def _ring_scan(count: int) -> tuple[MultiTargetState, list[list[Detection]]]:
    """``count`` confirmed tracks on a 1 km ring around two vehicles' area, each seen once by each vehicle."""
    rng = np.random.default_rng(count)
    angles = 2.0 * np.pi * np.arange(count) / count
    positions = 1000.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    mean = np.column_stack([positions, np.zeros((count, 2))])
    cov = np.tile(np.diag([25.0, 25.0, 1.0, 1.0]), (count, 1, 1))
    tracks = TrackSet.new(np.arange(1, count + 1), mean, cov, confirm_at_once=True)
    sensor = SENSORS[0]
    detections = []
    for vehicle, xyz in enumerate([np.array([0.0, 0.0, 200.0]), np.array([100.0, -50.0, 220.0])]):
        z = sensor.measure(positions + rng.normal(0.0, 3.0, positions.shape), xyz[None, :])
        detections.append([Detection(vehicle, xyz, values) for values in z])
    return MultiTargetState(tracks, 0, count + 1), detections


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_a_tracks_work_does_not_grow_with_the_other_tracks(association: str) -> None:
    tracker = MultiTargetTracker(association=association, clutter_density=1e-6)
    per_track = {}
    for count in (5, 20, 80):
        state, detections = _ring_scan(count)
        new_state, diagnostics = tracker.scan(state, 10**9, detections, SENSORS[0])
        assert diagnostics.associated == 2 * count  # every detection found its track
        per_track[count] = diagnostics.pairs_evaluated / count
    assert max(per_track.values()) <= 2.0 * 1.5  # two vehicles: one pair each, a neighbour's now and then
    assert per_track[80] <= per_track[5] * 1.5  # every track against every detection: 10, 40, then 160
