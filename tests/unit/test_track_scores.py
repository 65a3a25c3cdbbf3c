"""Track-level figures (gcs.core.metrics.track_scores) on hand-built runs."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.metrics import StepTracks, track_scores

A, B = np.array([0.0, 0.0]), np.array([100.0, 0.0])


def step(truths: dict, tracks: dict) -> StepTracks:
    return StepTracks(list(truths), np.array(list(truths.values())).reshape(-1, 2),
                      list(tracks), np.array(list(tracks.values())).reshape(-1, 2))


def test_perfect_run_scores_zero():
    run = [step({"t1": A + k, "t2": B + k}, {7: A + k + 0.5, 8: B + k - 0.5}) for k in range(5)]
    scores = track_scores(run, c=10.0)
    assert (scores.track_breaks, scores.id_swaps, scores.false_tracks, scores.false_track_steps, scores.missed) == (
        0, 0, 0, 0, 0)
    assert scores.truth_steps == 10
    assert scores.pairs[-1] == {"t1": 7, "t2": 8}


def test_swap_break_false_and_missed():
    run = [
        step({"t1": A, "t2": B}, {7: A, 8: B}),
        step({"t1": A, "t2": B}, {7: B, 8: A, "ghost": A + 50.0}),  # tracks 7 and 8 exchange truths; a ghost
        step({"t1": A, "t2": B}, {7: B}),  # t1's track 8 ends: a break, and t1 is missed
        step({"t1": A, "t2": B}, {7: B, 9: A}),  # t1 picked up by a new track 9: not a swap (9 never had t2)
    ]
    scores = track_scores(run, c=10.0)
    assert scores.id_swaps == 2  # step 1: t1 -> 8 (had t2), t2 -> 7 (had t1)
    assert scores.track_breaks == 3  # step 1 for both truths, step 2 for t1
    assert scores.false_tracks == 1 and scores.false_track_steps == 1  # "ghost", never paired, one step
    assert scores.missed == 1
    assert scores.pairs[2] == {"t1": None, "t2": 7}


def test_swap_after_a_gap_counts():
    run = [step({"t1": A, "t2": B}, {7: A, 8: B}), step({"t1": A, "t2": B}, {8: B}),
           step({"t1": A, "t2": B}, {8: A, 9: B})]
    scores = track_scores(run, c=10.0)
    assert scores.id_swaps == 1  # t1: last had 7, now 8 which had t2; t2 -> 9 is new, no swap
    assert scores.track_breaks == 2  # t1 at step 1 (7 ends), t2 at step 2 (8 -> 9)


def test_track_beyond_cutoff_is_false_and_truth_missed():
    scores = track_scores([step({"t1": A}, {1: A + 20.0})], c=10.0)
    assert (scores.missed, scores.false_tracks, scores.false_track_steps) == (1, 1, 1)


def test_ids_and_positions_must_match():
    with pytest.raises(ValueError):
        StepTracks(["t1", "t2"], np.zeros((1, 2)), [], np.zeros((0, 2)))
