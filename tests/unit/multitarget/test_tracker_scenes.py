"""MultiTargetTracker end to end: a noiseless crossing, a Monte Carlo with clutter and misses, the lifecycle."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import Lifecycle, MultiTargetTracker
from gcs.core.tracker import Detection

from ._scenes import CLUTTER_VOLUME, cv_truth, scan_detections

SENSOR = SensorModel.range_bearing(5.0, 0.005, 0.005)
STD = np.array(SENSOR.std)
VEHICLES = np.array([[-1200.0, -1000.0, 300.0], [1300.0, -900.0, 320.0], [100.0, 1400.0, 280.0]])
SECOND_NS = 1_000_000_000


def _run(tracker, scans):
    """Feed the scans (one list per vehicle each), 1 s apart; the states and diagnostics of every scan."""
    state = tracker.start()
    states, diagnostics = [], []
    for k, scan in enumerate(scans):
        state, diag = tracker.scan(state, k * SECOND_NS, scan, SENSOR)
        states.append(state)
        diagnostics.append(diag)
    return states, diagnostics


def _nearest_ids(state, targets: np.ndarray) -> list[int]:
    """The confirmed track nearest to each target (T, 2)."""
    confirmed = state.tracks.confirmed()
    gaps = np.linalg.norm(confirmed.mean[None, :, :2] - targets[:, None, :], axis=-1)
    return confirmed.ids[gaps.argmin(axis=1)].tolist()


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_noiseless_crossing_has_zero_error_and_keeps_its_ids(association: str) -> None:
    steps = 60
    t = np.arange(steps, dtype=float)[:, None]
    a = np.hstack([-400.0 + 12.0 * t, 0.0 * t])  # along the x axis
    b = np.hstack([-300.0 + 10.0 * t, -250.0 + 8.0 * t])  # crosses a's path ~40 m behind a (t = 31 s)
    truth = np.stack([a, b], axis=1)
    assert 30.0 < np.linalg.norm(a - b, axis=1).min() < 60.0
    tracker = MultiTargetTracker(association=association, motion=constant_velocity(0.5), detection_probability=1.0,
                                 clutter_density=1e-5)
    states, diagnostics = _run(tracker, [scan_detections(None, truth[k], VEHICLES, STD) for k in range(steps)])
    assert sum(d.initiations for d in diagnostics) == 2
    assert states[-1].tracks.confirmed().size == 2
    ids_before = _nearest_ids(states[20], truth[20])
    assert sorted(ids_before) == [1, 2]
    assert _nearest_ids(states[-1], truth[-1]) == ids_before
    final = states[-1].tracks
    by_id = {i: row for row, i in enumerate(final.ids.tolist())}
    error = np.array([final.mean[by_id[i], :2] - truth[-1, k] for k, i in enumerate(ids_before)])
    np.testing.assert_allclose(error, 0.0, atol=1e-6)
    velocity_error = np.array([final.mean[by_id[i], 2:] for i in ids_before]) - np.array([[12.0, 0.0], [10.0, 8.0]])
    np.testing.assert_allclose(velocity_error, 0.0, atol=1e-6)


@pytest.mark.parametrize("association", ["gnn", "jpda"])
def test_monte_carlo_five_targets_with_misses_and_clutter(association: str) -> None:
    runs, steps, targets, pd, clutter = 3, 30, 5, 0.9, 3.0
    psd = 0.05
    tracker = MultiTargetTracker(association=association, motion=constant_velocity(psd), detection_probability=pd,
                                 clutter_density=clutter / CLUTTER_VOLUME)
    nees, spurious = [], []
    for run in range(runs):
        rng = np.random.default_rng(1000 + run)
        start = np.column_stack([rng.uniform(-600, 600, (targets, 2)), rng.normal(0, 6, (targets, 2))])
        truth = cv_truth(rng, start, steps, 1.0, psd)
        scans = [scan_detections(rng, truth[k, :, :2], VEHICLES, STD, pd, clutter) for k in range(steps)]
        states, diagnostics = _run(tracker, scans)
        final = states[-1]
        confirmed = final.tracks.confirmed()
        assert confirmed.size == targets, f"run {run}: {confirmed.size} confirmed tracks"
        ids = _nearest_ids(final, truth[-1, :, :2])
        assert len(set(ids)) == targets
        assert _nearest_ids(states[steps // 2], truth[steps // 2, :, :2]) == ids  # the same id since mid-run
        spurious.append(sum(d.initiations for d in diagnostics) - targets)
        initiated = [i for d in diagnostics for i in d.initiated_ids]
        assert initiated == sorted(set(initiated))  # increasing, never reused
        for k, track_id in enumerate(ids):
            row = int(np.flatnonzero(confirmed.ids == track_id)[0])
            e = confirmed.mean[row, :2] - truth[-1, k, :2]
            nees.append(e @ np.linalg.solve(confirmed.cov[row, :2, :2], e))
    samples = len(nees)  # independent: different targets and runs
    low, high = chi2.ppf([0.0005, 0.9995], 2 * samples) / samples
    assert low <= np.mean(nees) <= high, f"average position NEES {np.mean(nees):.2f} outside [{low:.2f}, {high:.2f}]"
    assert max(spurious) > 0  # the clutter did start (and end) tentative tracks


def _single_target_scans(present: list[bool]) -> list[list[list[Detection]]]:
    target = np.array([100.0, 200.0])
    return [scan_detections(None, target[None] if seen else np.zeros((0, 2)), VEHICLES[:1], STD)
            for seen in present]


def test_three_of_four_confirms_on_the_third_hit_and_misses_delete_a_confirmed_track() -> None:
    tracker = MultiTargetTracker(confirm_m=3, confirm_n=4, max_misses=3)
    states, diagnostics = _run(tracker, _single_target_scans([True, True, False, True, False, False, False, True]))
    assert [s.tracks.status.tolist() for s in states[:4]] == [[0], [0], [0], [1]]
    assert diagnostics[3].confirmed_ids == (1,)
    assert states[5].tracks.size == 1 and diagnostics[6].deletions == 1
    assert diagnostics[6].deleted.ids.tolist() == [1]
    assert diagnostics[6].deleted.status.tolist() == [Lifecycle.DELETED]
    assert states[6].tracks.size == 0
    assert states[7].tracks.ids.tolist() == [2]  # the target again: a new id, never 1


def test_scans_on_which_no_sensor_covered_a_track_do_not_count_as_misses() -> None:
    tracker = MultiTargetTracker(confirm_m=1, confirm_n=1, max_misses=3, max_position_trace_m2=1e9)
    scans = _single_target_scans([True] + [False] * 8 + [True])
    covered = [True] * 3 + [False] * 6 + [True]  # the target goes behind buildings after two misses
    state, kept = tracker.start(), []
    for k, (scan, seen) in enumerate(zip(scans, covered)):
        state, diagnostics = tracker.scan(state, k * SECOND_NS, scan, SENSOR,
                                          in_view=lambda xy, seen=seen: np.full(len(xy), seen))
        kept.append((state.tracks.ids.tolist(), state.tracks.misses.tolist(), diagnostics.deletions))
    assert [misses for _, misses, _ in kept[:9]] == [[0], [1], [2]] + [[2]] * 6  # coasting, not missing
    assert all(ids == [1] for ids, _, _ in kept) and not any(d for _, _, d in kept)
    uncovered, _ = _run(tracker, scans)  # without the coverage the third miss deletes it
    assert uncovered[3].tracks.size == 0


def test_a_coasting_track_out_of_every_view_still_ends_at_the_covariance_bound() -> None:
    tracker = MultiTargetTracker(confirm_m=1, confirm_n=1, max_misses=3, max_position_trace_m2=2000.0)
    state, deleted_at = tracker.start(), None
    for k, scan in enumerate(_single_target_scans([True] + [False] * 9)):
        state, diagnostics = tracker.scan(state, k * SECOND_NS, scan, SENSOR,
                                          in_view=lambda xy: np.zeros(len(xy), dtype=bool))
        if diagnostics.deletions and deleted_at is None:
            deleted_at = k
    unbounded = MultiTargetTracker(confirm_m=1, confirm_n=1, max_misses=100, max_position_trace_m2=2000.0)
    _, by_trace = _run(unbounded, _single_target_scans([True] + [False] * 9))
    assert deleted_at == next(k for k, d in enumerate(by_trace) if d.deletions)


def test_a_tentative_track_that_cannot_reach_m_of_n_is_deleted() -> None:
    tracker = MultiTargetTracker(confirm_m=3, confirm_n=4, max_misses=5)
    states, diagnostics = _run(tracker, _single_target_scans([True, False, False]))
    assert states[1].tracks.size == 1  # one miss: 3 of 4 still possible
    assert diagnostics[2].deleted.ids.tolist() == [1] and states[2].tracks.size == 0


def test_a_track_whose_position_covariance_grows_past_the_bound_is_deleted() -> None:
    tracker = MultiTargetTracker(confirm_m=1, confirm_n=1, max_misses=100, max_position_trace_m2=2000.0)
    states, diagnostics = _run(tracker, _single_target_scans([True] + [False] * 6))
    traces = [np.trace(s.tracks.cov[0, :2, :2]) for s in states if s.tracks.size]
    deleted_at = next(k for k, d in enumerate(diagnostics) if d.deletions)
    assert all(tr <= 2000.0 for tr in traces) and deleted_at == len(traces)
    assert 1 < deleted_at < 6


def test_scan_mutates_nothing_and_returns_read_only_tracks() -> None:
    tracker = MultiTargetTracker(confirm_m=1, confirm_n=1)
    scans = _single_target_scans([True, True])
    first, _ = tracker.scan(tracker.start(), 0, scans[0], SENSOR)
    mean, cov = first.tracks.mean.copy(), first.tracks.cov.copy()
    second, _ = tracker.scan(first, SECOND_NS, scans[1], SENSOR)
    np.testing.assert_array_equal(first.tracks.mean, mean)
    np.testing.assert_array_equal(first.tracks.cov, cov)
    assert not np.array_equal(second.tracks.cov, cov)
    with pytest.raises(ValueError):
        second.tracks.mean[0, 0] = 0.0


def test_bearing_only_detections_do_not_start_tracks() -> None:
    sensor = SensorModel.bearing_only(0.01, 0.01)
    tracker = MultiTargetTracker()
    detection = Detection(0, VEHICLES[0], np.array([0.3, -0.2]))
    state, diagnostics = tracker.scan(tracker.start(), 0, [[detection]], sensor)
    assert state.tracks.size == 0 and diagnostics.unassociated == 1 and diagnostics.initiations == 0
