"""Stone Soup components that give the peers our trackers' scan-level lifecycle.

The peers feed Stone Soup one detection set per vehicle (:mod:`benchmarks.stonesoup_peer`),
so its stock components count sets: ``MultiMeasurementInitiator`` confirms after
``min_points`` updates and ``UpdateTimeStepsDeleter`` deletes after so many sets without
an update. Our trackers count scans, and a miss only where some UAV covered the track
(:mod:`gcs.core.multitarget.tracks`). These components apply the same rules in Stone
Soup's own interfaces (``Deleter.delete_tracks``, ``Initiator.initiate``); a
:class:`ScanClock` that the runner advances tells them which scan is being fed, its
coverage and whether the set is the scan's last, on which the rules are applied:

* a confirmed track is **hit** on a scan when some set updated it with a detection:
  ``GNNWith2DAssignment`` gave it one, or the JPDA's probability that one of the set's
  detections is the track's, ``1 - beta_0``, is at least one half (the tracker's
  :class:`~stonesoup.types.update.Update` with its ``MultipleHypothesis``);
* :class:`CoveredMissDeleter`: a scan without a hit counts a miss only where the
  scan's coverage says some UAV looked at the track's predicted position; ``max_misses``
  consecutive misses, or a position covariance trace above the bound, delete it;
* :class:`ScanInitiator`: tentative tracks confirmed by M hits in the last N scans,
  deleted once more than N - M of their first N scans are misses (the M-of-N rule of
  Blackman & Popoli 1999); tentative tracks are associated with ``GNNWith2DAssignment``
  after the confirmed ones, as in ``MultiMeasurementInitiator``;
* :class:`GroundInitiator`: a new track from one detection, Stone Soup's
  ``SimpleMeasurementInitiator`` (the inverse of the measurement model and its
  Jacobian) conditioned on the target's known height by a Kalman update with the
  pseudo-measurement ``z = target height``.

:class:`OrderedDetection` and :class:`NumberedTrack` hash by their place in the scan and
by their number, so the sets Stone Soup keeps them in iterate in the same order on every
run.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from stonesoup.base import Property
from stonesoup.dataassociator.base import DataAssociator
from stonesoup.deleter.base import Deleter
from stonesoup.initiator.base import Initiator
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.types.detection import Detection
from stonesoup.types.hypothesis import SingleHypothesis
from stonesoup.types.multihypothesis import MultipleHypothesis
from stonesoup.types.prediction import GaussianStatePrediction
from stonesoup.types.track import Track
from stonesoup.types.update import Update
from stonesoup.updater.base import Updater

__all__ = ["ScanClock", "OrderedDetection", "NumberedTrack", "detected_at", "CoveredMissDeleter", "ScanInitiator",
           "GroundInitiator"]

InView = Callable[[NDArray[np.float64]], NDArray[np.bool_]]
GROUND_VARIANCE_M2 = 1e-6
"""Variance of the height pseudo-measurement that puts a new track on the ground, m^2."""


class ScanClock:
    """The scan being fed: its time (every scan's, in order), its coverage, and whether the set is its last."""

    def __init__(self) -> None:
        self.times: list[datetime.datetime] = []
        self.in_view: InView | None = None
        self.closing = False

    def open(self, when: datetime.datetime, in_view: InView | None) -> None:
        """A new scan at ``when``; ``in_view`` maps ground positions (T, 2) to whether some UAV covered each."""
        self.times.append(when)
        self.in_view, self.closing = in_view, False


class OrderedDetection(Detection):
    """A detection hashed by ``metadata["order"]``, its (scan, vehicle, index) place."""

    def __hash__(self) -> int:
        return hash(self.metadata["order"])


class NumberedTrack(Track):
    """A track whose id is a number handed out in order, hashed by it."""

    def __hash__(self) -> int:
        return hash(int(self.id))


def _detection_mass(hypothesis) -> float:
    """The probability that the update took a detection: 1 or 0 for one hypothesis, ``1 - beta_0`` for a JPDA's."""
    if isinstance(hypothesis, MultipleHypothesis):
        weights = [(float(h.probability), bool(h)) for h in hypothesis]
        total = sum(w for w, _ in weights)
        return sum(w for w, found in weights if found) / total if total > 0.0 else 0.0
    return 1.0 if hypothesis else 0.0


def detected_at(track: Track, when: datetime.datetime) -> bool:
    """Whether some set of the scan at ``when`` updated ``track`` with a detection (module docstring)."""
    for state in reversed(track.states):
        if state.timestamp != when:
            return False
        if isinstance(state, Update) and _detection_mass(state.hypothesis) >= 0.5:
            return True
    return False


def _predicted_xy(track: Track, when: datetime.datetime) -> tuple[float, float]:
    """The track's ground position predicted to ``when``, before any set of that scan updated it."""
    first = track.state
    for state in reversed(track.states):
        if state.timestamp != when:
            break
        first = state
    if isinstance(first, Update):
        hypothesis = first.hypothesis
        first = (next(iter(hypothesis)) if isinstance(hypothesis, MultipleHypothesis) else hypothesis).prediction
    return float(first.state_vector[0, 0]), float(first.state_vector[2, 0])


class CoveredMissDeleter(Deleter):
    """Consecutive covered scans without a hit, or a position covariance too wide, delete a track."""

    clock: ScanClock = Property(doc="The scan being fed")
    max_misses: int = Property(doc="Consecutive covered scans without a hit that delete a track")
    max_position_var_m2: float = Property(doc="Bound on the trace of the (x, y) covariance")

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.misses: dict[Track, int] = {}

    def delete_tracks(self, tracks: set[Track], **kwargs) -> set[Track]:
        """On the scan's last set: count every track's hit or miss, return those to delete (none before)."""
        if not self.clock.closing or not tracks:
            return set()
        when = self.clock.times[-1]
        ordered = sorted(tracks, key=lambda t: int(t.id))
        looked = (np.ones(len(ordered), dtype=bool) if self.clock.in_view is None else
                  np.asarray(self.clock.in_view(np.array([_predicted_xy(t, when) for t in ordered])), dtype=bool))
        gone = set()
        for track, seen in zip(ordered, looked):
            misses = 0 if detected_at(track, when) else self.misses.get(track, 0) + int(seen)
            self.misses[track] = misses
            if self.check_for_deletion(track):
                gone.add(track)
                del self.misses[track]
        return gone

    def check_for_deletion(self, track: Track, **kwargs) -> bool:
        covar = track.covar
        trace = float(covar[0, 0] + covar[2, 2])
        return self.misses.get(track, 0) >= self.max_misses or not trace <= self.max_position_var_m2


class ScanInitiator(Initiator):
    """Tentative tracks held until M of the last N scans hit them (module docstring)."""

    clock: ScanClock = Property(doc="The scan being fed")
    initiator: Initiator = Property(doc="Starts a tentative track from one detection")
    data_associator: DataAssociator = Property(doc="Associates the tentative tracks with a set's detections")
    updater: Updater = Property(doc="Updates a tentative track with its detection")
    confirm_m: int = Property(doc="Hits that confirm")
    confirm_n: int = Property(doc="Of the last so many scans")

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.holding_tracks: set[Track] = set()
        self.hit_scans: dict[Track, set[datetime.datetime]] = {}
        self.born: dict[Track, int] = {}

    def initiate(self, detections, timestamp, **kwargs) -> set[Track]:
        """Update the tentative tracks with this set, confirm or drop them on the scan's last set, start new ones."""
        associated = set()
        if self.holding_tracks:
            for track, hypothesis in self.data_associator.associate(self.holding_tracks, detections,
                                                                    timestamp).items():
                if hypothesis:
                    track.append(self.updater.update(hypothesis))
                    associated.add(hypothesis.measurement)
                    self.hit_scans[track].add(timestamp)
                else:
                    track.append(hypothesis.prediction)
        sure = self._close() if self.clock.closing else set()
        for track in self.initiator.initiate(set(detections) - associated, timestamp):
            self.holding_tracks.add(track)
            self.hit_scans[track] = {timestamp}
            self.born[track] = len(self.clock.times) - 1
        return sure

    def _close(self) -> set[Track]:
        """Confirm the tentative tracks with M hits in their last N scans; drop the hopeless ones."""
        m, n, times = self.confirm_m, self.confirm_n, self.clock.times
        sure = set()
        for track in sorted(self.holding_tracks, key=lambda t: int(t.id)):
            age = len(times) - self.born[track]
            hits = sum(1 for when in times[-n:] if when in self.hit_scans[track])
            if hits >= m:
                sure.add(track)
            elif min(age, n) - hits <= n - m:
                continue
            self.holding_tracks.discard(track)
            del self.hit_scans[track], self.born[track]
        return sure


class GroundInitiator(Initiator):
    """Stone Soup's one-detection initiator, then the track put on the ground (module docstring)."""

    initiator: Initiator = Property(doc="A SimpleMeasurementInitiator on the detections' own models")
    updater: Updater = Property(doc="A KalmanUpdater for the height pseudo-measurement")
    target_height_m: float = Property(doc="The targets' known height, the state's z")
    ndim_state: int = Property(default=6, doc="State size; z is element 4")

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.next_id = 1
        self._ground = LinearGaussian(ndim_state=self.ndim_state, mapping=(4,),
                                      noise_covar=np.array([[GROUND_VARIANCE_M2]]))

    def initiate(self, detections, timestamp, **kwargs) -> set[Track]:
        """One numbered track per detection, in the detections' order."""
        tracks = set()
        for detection in sorted(detections, key=lambda d: d.metadata["order"]):
            (started,) = self.initiator.initiate({detection}, timestamp)
            state = started.state
            prior = GaussianStatePrediction(state.state_vector, state.covar, timestamp=state.timestamp)
            height = Detection(np.array([[self.target_height_m]]), timestamp=state.timestamp,
                               measurement_model=self._ground)
            tracks.add(NumberedTrack([self.updater.update(SingleHypothesis(prior, height))], id=str(self.next_id)))
            self.next_id += 1
        return tracks
