"""The set of tracks, as arrays, and their lifecycle: tentative -> confirmed -> deleted.

A :class:`TrackSet` holds T tracks side by side (row ``t`` of every array is
track ``t``), immutable: its arrays are read-only copies, and every operation
returns a new set.

Lifecycle (Blackman & Popoli 1999, track initiation and deletion; the M-of-N
"sliding window" confirmation logic):

* a track starts **tentative** from an unassociated detection
  (:mod:`gcs.core.multitarget.initiation`), its window holding that one hit;
* ``window`` keeps the last N scans as bits (bit 0 the newest; 1 = detected):
  a tentative track is **confirmed** once at least M of them are hits;
* a tentative track is **deleted** as soon as M of N can no longer be reached
  within its first N scans (more than ``N - M`` misses among them);
* any track is deleted after ``max_misses`` consecutive missed scans, or when the
  trace of its position covariance exceeds ``max_position_trace_m2`` (it has
  coasted so long that it no longer says where the target is);
* a missed scan counts only where a sensor looked: when the caller says which
  tracks were in some vehicle's view (``looked``), a scan on which a track was in
  no vehicle's view (behind buildings from every UAV, or out of range) leaves its
  consecutive-miss count as it was. Such a track coasts, and the covariance bound
  ends it once it has coasted too long; the missed detection it gets is
  ``1 - P_D`` only where ``P_D > 0`` (Blackman & Popoli 1999, track deletion with a
  state-dependent detection probability).

Ids are integers handed out in increasing order by the tracker and never
reused, so a deleted track's id never comes back.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

__all__ = ["Lifecycle", "TrackSet", "Advanced", "advance"]


class Lifecycle(IntEnum):
    """A track's state: only confirmed tracks are reported as targets."""

    TENTATIVE = 0
    CONFIRMED = 1
    DELETED = 2


@dataclass(frozen=True)
class TrackSet:
    """T tracks as arrays.

    Attributes
    ----------
    ids : ndarray of int64, shape (T,)
        Stable track ids.
    mean : ndarray, shape (T, 4)
        ``[x, y, vx, vy]`` (ENU m, m/s).
    cov : ndarray, shape (T, 4, 4)
    status : ndarray of int8, shape (T,)
        :class:`Lifecycle` values.
    window : ndarray of int64, shape (T,)
        Hits of the last N scans as bits, bit 0 the newest.
    age : ndarray of int64, shape (T,)
        Scans since initiation, 1 on the initiating scan.
    misses : ndarray of int64, shape (T,)
        Consecutive missed scans.
    """

    ids: NDArray[np.int64]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    status: NDArray[np.int8]
    window: NDArray[np.int64]
    age: NDArray[np.int64]
    misses: NDArray[np.int64]

    def __post_init__(self) -> None:
        dtypes = {"ids": np.int64, "mean": np.float64, "cov": np.float64, "status": np.int8,
                  "window": np.int64, "age": np.int64, "misses": np.int64}
        for f in fields(self):
            array = np.array(getattr(self, f.name), dtype=dtypes[f.name])  # a copy: the caller keeps theirs
            array.flags.writeable = False
            object.__setattr__(self, f.name, array)
        t = self.ids.shape[0]
        if self.mean.shape != (t, 4) or self.cov.shape != (t, 4, 4):
            raise ValueError(f"a track set of {t} ids needs mean (T, 4) and cov (T, 4, 4), got "
                             f"{self.mean.shape} and {self.cov.shape}")
        if any(getattr(self, name).shape != (t,) for name in ("status", "window", "age", "misses")):
            raise ValueError("status, window, age and misses must have one entry per track")

    @classmethod
    def empty(cls) -> TrackSet:
        """No tracks."""
        none = np.zeros(0, dtype=np.int64)
        return cls(none, np.zeros((0, 4)), np.zeros((0, 4, 4)), np.zeros(0, dtype=np.int8), none, none, none)

    @classmethod
    def new(cls, ids: NDArray[np.int64], mean: NDArray[np.float64], cov: NDArray[np.float64],
            confirm_at_once: bool) -> TrackSet:
        """Tracks just initiated: one hit, tentative (confirmed at once for a 1-of-N rule)."""
        k = len(ids)
        status = np.full(k, Lifecycle.CONFIRMED if confirm_at_once else Lifecycle.TENTATIVE, dtype=np.int8)
        one = np.ones(k, dtype=np.int64)
        return cls(ids, mean, cov, status, one, one, np.zeros(k, dtype=np.int64))

    @property
    def size(self) -> int:
        """Number of tracks T."""
        return int(self.ids.shape[0])

    def select(self, rows: NDArray[np.bool_] | NDArray[np.int64]) -> TrackSet:
        """The tracks at ``rows`` (a mask or indices)."""
        return TrackSet(*(getattr(self, f.name)[rows] for f in fields(self)))

    def with_estimates(self, mean: NDArray[np.float64], cov: NDArray[np.float64]) -> TrackSet:
        """The same tracks with new means (T, 4) and covariances (T, 4, 4)."""
        return TrackSet(self.ids, mean, cov, self.status, self.window, self.age, self.misses)

    def concat(self, other: TrackSet) -> TrackSet:
        """These tracks followed by ``other``'s."""
        return TrackSet(*(np.concatenate([getattr(self, f.name), getattr(other, f.name)]) for f in fields(self)))

    def confirmed(self) -> TrackSet:
        """The confirmed tracks alone."""
        return self.select(self.status == Lifecycle.CONFIRMED)


@dataclass(frozen=True)
class Advanced:
    """What :func:`advance` did: the tracks kept, those deleted (status DELETED) and the ids confirmed."""

    kept: TrackSet
    deleted: TrackSet
    confirmed_ids: NDArray[np.int64]


def advance(tracks: TrackSet, hit: NDArray[np.bool_], m: int, n: int, max_misses: int,
            max_position_trace_m2: float, looked: NDArray[np.bool_] | None = None,
            drop: NDArray[np.bool_] | None = None) -> Advanced:
    """One scan of the lifecycle for every track: record hits, confirm by M of N, delete.

    Parameters
    ----------
    tracks : TrackSet
        Tracks after this scan's update.
    hit : ndarray of bool, shape (T,)
        Whether each track was detected on this scan.
    m, n : int
        Confirmation rule: M hits in the last N scans, 1 <= M <= N <= 62.
    max_misses : int
        Consecutive misses that delete a track.
    max_position_trace_m2 : float
        Bound on ``tr P_pp`` above which a track is deleted.
    looked : ndarray of bool, shape (T,), optional
        Whether each track was in some vehicle's view on this scan; a track not
        looked at and not hit keeps its miss count. None: every track was looked at.
    drop : ndarray of bool, shape (T,), optional
        Tracks deleted whatever their hits (merged into another track).
    """
    if not 1 <= m <= n <= 62:
        raise ValueError(f"the M-of-N rule needs 1 <= M <= N <= 62, got M={m}, N={n}")
    hit = np.asarray(hit, dtype=bool)
    window = ((tracks.window << 1) | hit) & ((1 << n) - 1)
    age = tracks.age + 1
    looked = np.ones(tracks.size, dtype=bool) if looked is None else np.asarray(looked, dtype=bool)
    if looked.shape != hit.shape:
        raise ValueError(f"looked needs one entry per track, got shape {looked.shape} for {tracks.size} tracks")
    misses = np.where(hit, 0, tracks.misses + looked)
    hits = np.bitwise_count(window).astype(np.int64)
    tentative = tracks.status == Lifecycle.TENTATIVE
    confirm = tentative & (hits >= m)
    status = np.where(confirm, Lifecycle.CONFIRMED, tracks.status).astype(np.int8)
    hopeless = tentative & ~confirm & (np.minimum(age, n) - hits > n - m)
    trace = tracks.cov[:, 0, 0] + tracks.cov[:, 1, 1]
    delete = hopeless | (misses >= max_misses) | ~(trace <= max_position_trace_m2)
    if drop is not None:
        delete |= np.asarray(drop, dtype=bool)
    updated = TrackSet(tracks.ids, tracks.mean, tracks.cov, status, window, age, misses)
    gone = updated.select(delete)
    gone = TrackSet(gone.ids, gone.mean, gone.cov, np.full(gone.size, Lifecycle.DELETED), gone.window, gone.age,
                    gone.misses)
    return Advanced(updated.select(~delete), gone, tracks.ids[confirm & ~delete])
