"""Track-level figures over a run: track breaks, id swaps, false tracks, missed truth-steps.

At every time step the truths are paired with the tracks by the GOSPA assignment
(:func:`gcs.core.metrics.gospa.gospa`: minimum ``sum d^p`` with only pairs closer
than the cut-off ``c``), in the spirit of the track-level counts of Ristic, Vo,
Clark & Vo, "A metric for performance evaluation of multi-target tracking
algorithms", IEEE Trans. Signal Processing 59(7), 2011, and of the ID switches and
fragmentations of CLEAR MOT (Bernardin & Stiefelhagen 2008). With ``a_k(i)`` the
track paired with truth ``i`` at step ``k`` (or none), counting only steps at which
truth ``i`` exists, and ``k'`` the previous such step:

* **track break**: ``a_{k'}(i)`` is a track and ``a_k(i) != a_{k'}(i)``: the truth's
  track ended, was lost (moved beyond ``c``) or was replaced;
* **id swap**: ``a_k(i)`` is a track ``b``, differs from the last track truth ``i``
  had (``b`` after a gap counts too), and ``b`` was paired with another truth
  ``j != i`` at some earlier step;
* **false tracks**: ``false_tracks`` counts the track ids never paired with any
  truth over the whole run; ``false_track_steps`` counts the (track, step) pairs left
  unpaired, the per-step count summed (GOSPA's false part divided by ``c^p / 2``);
* **missed**: the truth-steps with no track paired.

Ids are any hashable values (str or int); a step lists the truths and tracks that
exist at that time with their 2-D positions.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.metrics.gospa import as_points, gospa

__all__ = ["StepTracks", "TrackScores", "track_scores"]


@dataclass(frozen=True)
class StepTracks:
    """One time step: truth ids with positions (n, 2), track ids with positions (m, 2), metres."""

    truth_ids: Sequence[Hashable]
    truth_xy: NDArray[np.float64]
    track_ids: Sequence[Hashable]
    track_xy: NDArray[np.float64]

    def __post_init__(self) -> None:
        if len(as_points(self.truth_xy)) != len(self.truth_ids) or len(as_points(self.track_xy)) != len(self.track_ids):
            raise ValueError("every id needs one position and every position one id")


@dataclass(frozen=True)
class TrackScores:
    """Counts over a run (definitions in the module docstring); ``pairs`` is, per step, truth id -> track id."""

    track_breaks: int
    id_swaps: int
    false_tracks: int
    false_track_steps: int
    missed: int
    truth_steps: int
    pairs: tuple[dict[Hashable, Hashable | None], ...]


def track_scores(steps: Sequence[StepTracks], c: float, p: float = 2.0) -> TrackScores:
    """Track breaks, id swaps, false tracks and missed truth-steps over ``steps`` (in time order)."""
    previous: dict[Hashable, Hashable | None] = {}  # truth -> track at its previous step (None when unpaired)
    last_track: dict[Hashable, Hashable] = {}  # truth -> the last track it was paired with
    owners: dict[Hashable, set[Hashable]] = {}  # track -> truths it has been paired with so far
    seen_tracks: set[Hashable] = set()
    breaks = swaps = false_steps = missed = truth_steps = 0
    pairs: list[dict[Hashable, Hashable | None]] = []
    for step in steps:
        result = gospa(step.track_xy, step.truth_xy, c, p)
        paired = {truth: (step.track_ids[j] if j >= 0 else None) for truth, j in zip(step.truth_ids, result.assignment)}
        for truth, track in paired.items():
            if previous.get(truth) is not None and track != previous[truth]:
                breaks += 1
            if track is not None:
                earlier = last_track.get(truth)
                if earlier is not None and track != earlier and owners.get(track, set()) - {truth}:
                    swaps += 1
                last_track[truth] = track
            previous[truth] = track
        for truth, track in paired.items():  # owners are updated after the step: a swap needs an EARLIER pairing
            if track is not None:
                owners.setdefault(track, set()).add(truth)
        seen_tracks.update(step.track_ids)
        missed += result.missed_count
        false_steps += result.false_count
        truth_steps += len(step.truth_ids)
        pairs.append(paired)
    false_tracks = sum(1 for track in seen_tracks if track not in owners)
    return TrackScores(breaks, swaps, false_tracks, false_steps, missed, truth_steps, tuple(pairs))
