"""Lost targets: deleted confirmed tracks kept, predicted on, and forgotten when found again or too old."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget.lost import LostTargets
from gcs.core.multitarget.tracks import TrackSet

MOTION = constant_velocity(2.0)


def _tracks(ids, xy, std_m=10.0, misses=0) -> TrackSet:
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    mean = np.column_stack([xy, np.full(len(xy), 5.0), np.zeros(len(xy))])
    cov = np.tile(np.diag([std_m**2, std_m**2, 4.0, 4.0]), (len(xy), 1, 1))
    tracks = TrackSet.new(np.asarray(ids, dtype=np.int64), mean, cov, confirm_at_once=True)
    return TrackSet(tracks.ids, tracks.mean, tracks.cov, tracks.status, tracks.window, tracks.age,
                    np.full(len(xy), misses, dtype=np.int64))


def test_only_deleted_tracks_that_were_confirmed_are_kept_with_their_missed_time() -> None:
    lost = LostTargets.none().add(_tracks([4, 7], [[0.0, 0.0], [100.0, 0.0]], misses=5), np.array([False, True]), 1.0)
    assert lost.ids.tolist() == [7] and lost.unseen_s.tolist() == [5.0]
    np.testing.assert_array_equal(lost.mean[0, :2], [100.0, 0.0])


def test_the_time_unseen_may_be_given_instead_of_the_missed_scans() -> None:
    """A track that coasted out of every sensor's view missed no scan, yet went unseen for a while."""
    deleted = _tracks([4, 7], [[0.0, 0.0], [100.0, 0.0]], misses=2)
    lost = LostTargets.none().add(deleted, np.array([True, True]), 1.0, np.array([30.0, 12.5]))
    assert lost.ids.tolist() == [4, 7] and lost.unseen_s.tolist() == [30.0, 12.5]


def test_a_lost_target_is_predicted_with_the_motion_model() -> None:
    lost = LostTargets.none().add(_tracks([1], [[0.0, 0.0]], misses=5), np.array([True]), 1.0)
    f, q = MOTION.matrices(2.0)
    moved = lost.advance(MOTION, 2.0)
    np.testing.assert_allclose(moved.mean[0], f @ lost.mean[0])
    np.testing.assert_allclose(moved.cov[0], f @ lost.cov[0] @ f.T + q)
    assert moved.mean[0, 0] == 10.0 and moved.unseen_s[0] == 7.0
    assert moved.cov[0, 0, 0] > lost.cov[0, 0, 0]


def test_a_lost_target_is_forgotten_when_a_confirmed_track_finds_it_or_when_too_old() -> None:
    gate = float(chi2.ppf(0.999, 2))
    lost = LostTargets.none().add(_tracks([1, 2, 3], [[0.0, 0.0], [500.0, 0.0], [900.0, 0.0]], misses=5),
                                  np.ones(3, dtype=bool), 1.0)
    lost = LostTargets(lost.ids, lost.mean, lost.cov, np.array([5.0, 5.0, 120.0]))
    # a confirmed track 20 m from target 1 (combined sigma 14 m: d^2 = 2, inside); one 200 m from target 2 (outside)
    confirmed = _tracks([9, 10], [[20.0, 0.0], [700.0, 0.0]])
    kept = lost.forget(confirmed, gate, forget_s=90.0)
    assert kept.ids.tolist() == [2]
    assert lost.forget(_tracks([], []), gate, forget_s=90.0).ids.tolist() == [1, 2]
