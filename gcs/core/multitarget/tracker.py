"""The multi-target tracker: one scan of every vehicle's identity-free detections -> a new set of tracks.

``MultiTargetTracker(config...).scan(state, stamp_ns, detections_by_vehicle, sensor)``
returns ``(new_state, diagnostics)`` and mutates nothing. One scan:

1. predict every track to ``stamp_ns`` (:func:`gcs.core.multitarget.filter.predict`);
2. for each vehicle, every track against every detection that can pass its gate
   (:mod:`~gcs.core.multitarget.candidates`) at once: innovations, the chi-square gate (:mod:`~gcs.core.multitarget.gating`) and the association,
   GNN (:mod:`~gcs.core.multitarget.gnn`) or JPDA (:mod:`~gcs.core.multitarget.jpda`),
   turned into position-block information contributions per track;
3. sum the contributions over vehicles and fuse them into every track
   (wang2012 eq. 14-15, :func:`~gcs.core.multitarget.filter.information_update`);
4. advance the lifecycle (M-of-N confirmation, deletion, a miss counted only where a
   sensor covered the track; :mod:`~gcs.core.multitarget.tracks`);
5. start tentative tracks from the detections no track took
   (:mod:`~gcs.core.multitarget.initiation`), with ids never used before.

A track counts as detected on a scan when some vehicle's association gave it a
detection: GNN assigned it one, or the JPDA's probability that one of the
vehicle's detections is the track's, ``1 - beta_t0``, is at least one half.
"Unassociated" detections, which may start tracks, are those GNN assigned to
no track, or, for the JPDA, those outside every track's gate (a detection
inside a gate has already been weighed in that track's update).

JPDA and several vehicles. One vehicle's PDA posterior is always a proper
Gaussian, but the sum over vehicles of their information contributions can
fail to be positive definite when the spread-of-innovations terms widen
several vehicles' posteriors (the contributions are then indefinite). For such
a track the contributions are averaged over the vehicles instead of summed, a
convex combination of the vehicles' proper posteriors in information form,
hence proper; :attr:`ScanDiagnostics.fusion_fallbacks` counts it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import NS_PER_S
from gcs.core.models.motion import LinearMotionModel, constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.batches import DetectionBatch, detection_batches
from gcs.core.multitarget.candidates import candidate_pairs
from gcs.core.multitarget.diagnostics import ScanDiagnostics, scan_diagnostics
from gcs.core.multitarget.gating import gate, gate_threshold
from gcs.core.multitarget.gnn import assignment_costs, gnn_assign
from gcs.core.multitarget.initiation import ground_positions, initial_states, merge_candidates, starts_tracks
from gcs.core.multitarget.jpda import DEFAULT_MAX_HYPOTHESES, jpda_marginals
from gcs.core.multitarget.road_clouds import TrackClouds
from gcs.core.multitarget.tracks import TrackSet, advance
from gcs.core.tracker import Detection

__all__ = ["MultiTargetTracker", "MultiTargetState", "ScanDiagnostics"]

ASSOCIATIONS = ("gnn", "jpda")


@dataclass(frozen=True)
class MultiTargetState:
    """The tracker's memory: the tracks, the stamp they are at (None before the first scan), the next id; and,
    for the road tracker (:mod:`~gcs.core.multitarget.road_tracker`), the rest of each track's state, row for row."""

    tracks: TrackSet = field(default_factory=TrackSet.empty)
    stamp_ns: int | None = None
    next_id: int = 1
    clouds: TrackClouds | None = None


@dataclass(frozen=True)
class MultiTargetTracker:
    """Parameters of the multi-target tracker; holds no tracks.

    Parameters
    ----------
    association : str
        ``"gnn"`` or ``"jpda"``.
    motion : LinearMotionModel
        The ``cv2d`` white-noise acceleration model.
    detection_probability, gate_probability : float
        ``P_D`` and ``P_G``.
    clutter_density : float
        ``lambda``: false detections per unit volume of measurement space (the
        product of the sensor's component units, e.g. m rad^2), > 0.
    confirm_m, confirm_n : int
        The M-of-N confirmation rule.
    max_misses : int
        Consecutive missed scans that delete a track.
    max_position_trace_m2 : float
        A track whose ``tr P_pp`` exceeds this is deleted.
    initial_velocity_std_mps : float
        Velocity standard deviation per axis of a new track.
    max_hypotheses : int
        JPDA cap per cluster (:mod:`gcs.core.multitarget.jpda`).
    """

    association: str = "gnn"
    motion: LinearMotionModel = field(default_factory=lambda: constant_velocity(1.0))
    detection_probability: float = 0.9
    gate_probability: float = 0.99
    clutter_density: float = 1e-6
    confirm_m: int = 3
    confirm_n: int = 4
    max_misses: int = 3
    max_position_trace_m2: float = 1e6
    initial_velocity_std_mps: float = 10.0
    max_hypotheses: int = DEFAULT_MAX_HYPOTHESES

    def __post_init__(self) -> None:
        if self.association not in ASSOCIATIONS:
            raise ValueError(f"association must be one of {ASSOCIATIONS}, got {self.association!r}")
        if not 0.0 < self.detection_probability <= 1.0:
            raise ValueError(f"detection_probability must be in (0, 1], got {self.detection_probability!r}")
        gate_threshold(self.gate_probability, 1)
        if not 1 <= self.confirm_m <= self.confirm_n <= 62:
            raise ValueError(f"need 1 <= confirm_m <= confirm_n <= 62, got {self.confirm_m} of {self.confirm_n}")
        if self.max_misses < 1:
            raise ValueError(f"max_misses must be >= 1, got {self.max_misses}")

    def start(self) -> MultiTargetState:
        """No tracks yet."""
        return MultiTargetState()

    def scan(self, state: MultiTargetState, stamp_ns: int,
             detections_by_vehicle: Mapping[int, Sequence[Detection]] | Sequence[Sequence[Detection]],
             sensor: SensorModel | Sequence[SensorModel],
             in_view: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None = None,
             ) -> tuple[MultiTargetState, ScanDiagnostics]:
        """Fuse one scan: every vehicle's detections taken at ``stamp_ns`` (int, ns).

        ``detections_by_vehicle`` holds one sequence of detections per vehicle (a
        mapping by vehicle index, or a sequence); ``sensor`` is every vehicle's
        model, or one per vehicle indexed by :attr:`Detection.vehicle`.
        ``in_view`` maps the tracks' predicted ground positions (T, 2) to whether
        some vehicle's sensor covered each (T,) on this scan (in range, with a line
        of sight past the buildings); a track out of every view is not counted
        missed (:mod:`~gcs.core.multitarget.tracks`). None: every track was covered.
        """
        dt_s = elapsed_s(state, stamp_ns)
        batches = detection_batches(detections_by_vehicle, sensor)
        tracks = state.tracks
        mean, cov = tracks.mean, tracks.cov
        if dt_s > 0.0 and tracks.size:
            mean, cov = batched.predict(mean, cov, dt_s, self.motion)
        predicted_xy = mean[:, :2]
        a_parts, b_parts = [], []
        hit = np.zeros(tracks.size, dtype=bool)
        counts = {"gated": 0, "associated": 0, "clusters": 0, "over": 0, "pairs": 0}
        free = []  # per batch: detections no track took
        detected_by = {}
        for batch in batches:
            a, b, detected, used = self._associate(mean, cov, batch, counts)
            a_parts.append(a)
            b_parts.append(b)
            hit |= detected
            free.append(~used)
            detected_by[batch.vehicle] = tuple(tracks.ids[detected].tolist())
        fallbacks = 0
        if a_parts:
            a_sum, b_sum = np.sum(a_parts, axis=0), np.sum(b_parts, axis=0)
            new_mean, new_cov = batched.information_update(mean, cov, a_sum, b_sum)
            bad = ~_position_definite(new_cov)
            if bad.any():
                fallbacks = int(bad.sum())
                a_sum[bad] /= len(a_parts)
                b_sum[bad] /= len(b_parts)
                new_mean, new_cov = batched.information_update(mean, cov, a_sum, b_sum)
            mean, cov = new_mean, new_cov
        looked = None if in_view is None or not tracks.size else np.asarray(in_view(predicted_xy), dtype=bool)
        advanced = advance(tracks.with_estimates(mean, cov), hit, self.confirm_m, self.confirm_n, self.max_misses,
                           self.max_position_trace_m2, looked)
        born = self._initiate(batches, free, state.next_id, advanced.kept)
        new_state = MultiTargetState(advanced.kept.concat(born), int(stamp_ns), state.next_id + born.size)
        return new_state, scan_diagnostics(batches, counts, advanced, born, detected_by, fallbacks)

    def _associate(self, mean: NDArray[np.float64], cov: NDArray[np.float64], batch: DetectionBatch,
                   counts: dict[str, int]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
        """One vehicle: contributions ``A`` (T, 2, 2), ``b`` (T, 2), tracks detected (T,), detections used (n,)."""
        inn, valid = self._gated(mean, cov, batch, counts)
        costs = assignment_costs(inn.log_likelihood, valid, self.detection_probability, self.gate_probability,
                                 self.clutter_density)
        beta, detected, used = self._beta(costs, valid, counts)
        if self.association == "gnn":
            a, b = batched.assigned_contributions(inn, np.where(detected, beta.argmax(axis=1), -1))
        else:
            a, b = batched.mixture_contributions(inn, beta, cov[:, :2, :2])
        return a, b, detected, used

    def _gated(self, mean: NDArray[np.float64], cov: NDArray[np.float64], batch: DetectionBatch,
               counts: dict[str, int]) -> tuple[batched.Innovations, NDArray[np.bool_]]:
        """Innovations of the tracks (T, 4) against one vehicle's detections, and the gate (T, n): only the pairs
        that can pass it are evaluated (:mod:`~gcs.core.multitarget.candidates`)."""
        gamma = gate_threshold(self.gate_probability, batch.sensor.dim)
        pairs = candidate_pairs(mean, cov, batch.sensor, batch.z, batch.xyz, batch.pcov, gamma)
        inn = batched.innovations(mean, cov, batch.sensor, batch.z, batch.xyz, batch.pcov, pairs)
        valid = gate(inn.d2, self.gate_probability, batch.sensor.dim)
        counts["gated"] += int(valid.any(axis=0).sum())
        counts["pairs"] += inn.pairs
        return inn, valid

    def _beta(self, costs: NDArray[np.float64], valid: NDArray[np.bool_], counts: dict[str, int]
              ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
        """Association probabilities ``beta`` (T, n) by GNN (one-hot) or JPDA, the tracks detected (T,) and the
        detections used (n,) (the module docstring's rules)."""
        t_count, n_count = costs.shape
        if self.association == "gnn":
            assigned = gnn_assign(costs)
            detected = assigned >= 0
            beta = np.zeros((t_count, n_count))
            beta[np.flatnonzero(detected), assigned[detected]] = 1.0
            used: NDArray[np.bool_] = np.any(beta, axis=0)
        else:
            result = jpda_marginals(costs, valid, self.max_hypotheses)
            beta = result.beta
            used = np.any(valid, axis=0)
            detected = beta.sum(axis=1) >= 0.5
            counts["clusters"] += result.clusters
            counts["over"] += result.clusters_over_cap
        counts["associated"] += int(used.sum())
        return beta, detected, used

    def _initiate(self, batches: Sequence[DetectionBatch], free: Sequence[NDArray[np.bool_]], next_id: int,
                  existing: TrackSet) -> TrackSet:
        """Tentative tracks from the free detections (:meth:`_new_positions`), ids from ``next_id``."""
        p, c = self._new_positions(batches, free, existing)
        mean, cov = initial_states(p, c, self.initial_velocity_std_mps)
        ids = np.arange(next_id, next_id + p.shape[0], dtype=np.int64)
        return TrackSet.new(ids, mean, cov, confirm_at_once=self.confirm_m <= 1)

    def _new_positions(self, batches: Sequence[DetectionBatch], free: Sequence[NDArray[np.bool_]], existing: TrackSet
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Ground positions (k, 2) and covariances (k, 2, 2) of new tracks: the free detections of range-bearing
        sensors, merged across vehicles.

        A candidate whose ground position agrees with an existing track's (the
        2-dof chi-square gate on the difference, covariance ``P_track,pp + P_candidate``)
        starts nothing: it is that target seen again, left out of the update
        only because its measurement gate was missed, and a track started from it
        would be a duplicate."""
        positions, covs, vehicles = [], [], []
        for batch, mask in zip(batches, free):
            if not (mask.any() and starts_tracks(batch.sensor)):
                continue
            p, c = ground_positions(batch.sensor, batch.z[mask], batch.xyz[mask], batch.pcov[mask])
            positions.append(p)
            covs.append(c)
            vehicles.append(np.full(p.shape[0], batch.vehicle))
        if not positions:
            return np.zeros((0, 2)), np.zeros((0, 2, 2))
        p, c = merge_candidates(np.concatenate(positions), np.concatenate(covs), np.concatenate(vehicles),
                                gate_threshold(self.gate_probability, 2))
        threshold = gate_threshold(self.gate_probability, 2)
        if existing.size and p.shape[0]:
            diff = p[:, None, :] - existing.mean[None, :, :2]  # (k, T, 2)
            total = c[:, None] + existing.cov[None, :, :2, :2]
            d2 = np.einsum("kti,kti->kt", diff, np.linalg.solve(total, diff[..., None])[..., 0])
            keep = ~(d2 <= threshold).any(axis=1)
            p, c = p[keep], c[keep]
        return p, c


def elapsed_s(state: MultiTargetState, stamp_ns: int) -> float:
    """Seconds from the tracks' stamp to ``stamp_ns`` (0 before the first scan); TypeError for a stamp that is no
    integer, ValueError for one older than the tracks."""
    if not isinstance(stamp_ns, (int, np.integer)) or isinstance(stamp_ns, bool):
        raise TypeError(f"stamp_ns must be an integer number of nanoseconds, got {type(stamp_ns).__name__}")
    if state.stamp_ns is None:
        return 0.0
    dt_s = (int(stamp_ns) - state.stamp_ns) / NS_PER_S
    if dt_s < 0.0:
        raise ValueError(f"scan at {stamp_ns} ns is older than the tracks ({state.stamp_ns} ns)")
    return dt_s


def _position_definite(cov: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each (T, 4, 4) covariance's position block is positive definite (2 x 2 test)."""
    pxx, pxy, pyy = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    return (pxx > 0.0) & (pxx * pyy - pxy * pxy > 0.0)
