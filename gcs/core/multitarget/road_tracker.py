"""The multi-target tracker on the road graph: every track a particle cloud on the roads, associated by its cloud.

:class:`RoadMultiTargetTracker` is :class:`~gcs.core.multitarget.tracker.MultiTargetTracker`
(the same gate, GNN or JPDA, initiation and M-of-N lifecycle) with each track's
Gaussian replaced by a particle cloud on the road graph with an off-road mode
(:mod:`~gcs.core.multitarget.road_clouds`; the motion of
:class:`gcs.core.roads.particle.RoadParticleFilter`: the particles branch at
junctions and drive on along the streets while no vehicle sees the car). One scan:

1. every cloud is driven to ``stamp_ns`` (:meth:`RoadParticleFilter.move`), and its
   moment-matched Gaussian (:meth:`TrackClouds.summary`) is the track's predicted
   state for the gate (the road spread added to its position covariance);
2. for each vehicle that scanned, with detections or without: the detection
   probability of every particle from the vehicle's sight of it, the cloud's
   association costs, GNN or JPDA on them, and the mixture update of the
   particles' weights (:mod:`~gcs.core.multitarget.road_association`: negative
   information included); the vehicles' factors multiply (their detections are
   independent given the target, as in the information sum of wang2012 eq. 14);
3. degenerate clouds are resampled (:func:`~gcs.core.multitarget.road_clouds.resample_degenerate`);
4. the lifecycle advances on the clouds' summaries: a miss counts where the
   cloud was more likely than not in some vehicle's sight;
5. new tracks start from the free detections (as the Gaussian tracker's), each a
   cloud drawn about the detection and put on the nearest roads.

Randomness (the motion's noise, the branch draws, resampling) comes from the
generator of the single-target road tracker's update, seeded by ``seed`` and
``stamp_ns`` (:meth:`gcs.core.roads.tracking.RoadTracking.generator`), so the same
scans give the same tracks, bit for bit, live or replayed. The tracks' ``mean`` and ``cov`` are the clouds' summaries.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget.batches import DetectionBatch, detection_batches
from gcs.core.multitarget.diagnostics import ScanDiagnostics, scan_diagnostics
from gcs.core.multitarget.gating import gate_threshold
from gcs.core.multitarget.initiation import initial_states
from gcs.core.multitarget.road_association import (costs_of, detection_probabilities, mixture_log_weights,
                                                   particle_terms)
from gcs.core.multitarget.road_clouds import TrackClouds, drive, resample_degenerate, start_clouds
from gcs.core.multitarget.road_existence import existence_log_ratio, predicted_existence, updated_existence
from gcs.core.multitarget.road_merging import merged, unresolved
from gcs.core.multitarget.tracker import MultiTargetState, MultiTargetTracker, elapsed_s
from gcs.core.multitarget.tracks import Lifecycle, TrackSet, advance
from gcs.core.roads.outputs import normalise_log_weights
from gcs.core.roads.particle import RoadParticleFilter
from gcs.core.roads.sensing import Sees
from gcs.core.roads.tracking import FUSE_STREAM, RoadTracking
from gcs.core.tracker import Detection

__all__ = ["RoadMultiTargetTracker"]


@dataclass(frozen=True)
class RoadMultiTargetTracker(MultiTargetTracker):
    """:class:`MultiTargetTracker`'s parameters, and the road's (module docstring).

    Parameters
    ----------
    roads : RoadParticleFilter
        The road graph and the motion on and off it (its ``resample_threshold`` and
        ``spread_m`` too; its ``particles`` is not used: see ``particles``).
    sees : callable or None
        ``sees(points (P, 2), vehicle_xyz (V, 3)) -> (V, P)``: in the sensor's field
        and in sight (:func:`gcs.core.roads.sensing.table_sees`). None: no negative
        information from the particles; a track is detected with ``P_D`` where
        ``in_view`` says its mean is in view and ``kappa P_D`` elsewhere (``P_D``
        everywhere without ``in_view``).
    particles : int
        Particles per track.
    detection_floor : float
        ``kappa``: a particle out of a vehicle's sight is detected with ``kappa P_D``
        (the sight test is approximate).
    lane_std_m, lateral_psd_m2_s, lateral_limit_m : float
        A road particle's offset from the centre line (the lanes, the street's width):
        drawn ``N(0, lane_std_m^2)`` at birth, then a random walk of that density,
        kept within the limit (:func:`~gcs.core.multitarget.road_clouds.drive`).
    merge_scans, merge_overlap, merge_probability
        The merging of unresolved tracks (:mod:`~gcs.core.multitarget.road_merging`):
        the scans in a row, the shared road weight ``o_min`` and the gate's probability.
    survival_per_s, initial_existence, min_existence : float
        IPDA's existence (:mod:`~gcs.core.multitarget.road_existence`): ``p_s`` a second,
        a new track's ``r``, and the ``r`` under which a track is deleted.
    seed : int
        Mixed with each scan's stamp into the scan's generator (>= 0).
    """

    roads: RoadParticleFilter | None = None
    sees: Sees | None = None
    particles: int = 200
    detection_floor: float = 0.02
    lane_std_m: float = 4.0
    lateral_psd_m2_s: float = 0.1
    lateral_limit_m: float = 10.0
    merge_scans: int = 5
    merge_overlap: float = 0.5
    merge_probability: float = 0.99
    survival_per_s: float = 0.99
    initial_existence: float = 0.5
    min_existence: float = 0.05
    seed: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.road_filter, RoadParticleFilter):
            raise TypeError(f"roads must be a RoadParticleFilter, got {type(self.roads).__name__}")
        if self.particles < 2:
            raise ValueError(f"particles must be >= 2, got {self.particles}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")
        if not 0.0 < self.detection_floor <= 1.0:
            raise ValueError(f"detection_floor must be in (0, 1], got {self.detection_floor!r}")

    @property
    def road_filter(self) -> RoadParticleFilter:
        """``roads``, which :meth:`__post_init__` checked is a :class:`RoadParticleFilter`."""
        if not isinstance(self.roads, RoadParticleFilter):
            raise TypeError(f"roads must be a RoadParticleFilter, got {type(self.roads).__name__}")
        return self.roads

    def start(self) -> MultiTargetState:
        """No tracks yet."""
        return MultiTargetState(clouds=TrackClouds.empty(self.particles))

    def scan(self, state: MultiTargetState, stamp_ns: int,
             detections_by_vehicle: Mapping[int, Sequence[Detection]] | Sequence[Sequence[Detection]],
             sensor: SensorModel | Sequence[SensorModel],
             in_view: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None = None,
             vehicles: Mapping[int, NDArray[np.float64]] | None = None,
             ) -> tuple[MultiTargetState, ScanDiagnostics]:
        """Fuse one scan (module docstring); arguments as :meth:`MultiTargetTracker.scan`, and ``vehicles``: where
        every vehicle that scanned was (vehicle index -> ENU (3,)), those that detected nothing included; None:
        the vehicles with detections."""
        dt_s = elapsed_s(state, stamp_ns)
        rng = RoadTracking(self.road_filter, seed=self.seed).generator(stamp_ns, FUSE_STREAM)
        batches = detection_batches(detections_by_vehicle, sensor)
        tracks = state.tracks
        clouds = state.clouds if state.clouds is not None else TrackClouds.empty(self.particles)
        if dt_s > 0.0 and tracks.size:
            clouds = drive(self.road_filter, clouds, dt_s, self.lateral_psd_m2_s, self.lateral_limit_m, rng)
            clouds = replace(clouds, existence=predicted_existence(clouds.existence, self.survival_per_s, dt_s))
        weighed = self._weigh(tracks, clouds, batches, _lookers(batches, vehicles), in_view)
        clouds = resample_degenerate(self.road_filter, weighed.clouds, self.road_filter.resample_threshold, rng)
        tracks = tracks.with_estimates(*clouds.summary(self.road_filter.graph)) if tracks.size else tracks
        drop, unresolved_scans = self._merged(tracks, clouds)
        drop |= clouds.existence < self.min_existence
        advanced = advance(tracks, weighed.hit, self.confirm_m, self.confirm_n, self.max_misses,
                           self.max_position_trace_m2, weighed.looked, drop)
        clouds = replace(clouds, unresolved=unresolved_scans).select(np.isin(tracks.ids, advanced.kept.ids))
        free = [weighed.free[b.vehicle] for b in batches]
        born, born_clouds = self._born(batches, free, state.next_id, advanced.kept, rng)
        new_state = MultiTargetState(advanced.kept.concat(born), int(stamp_ns), state.next_id + born.size,
                                     clouds.concat(born_clouds))
        return new_state, scan_diagnostics(batches, weighed.counts, advanced, born, weighed.detected_by)

    def _weigh(self, tracks: TrackSet, clouds: TrackClouds, batches: Sequence[DetectionBatch],
               lookers: Mapping[int, NDArray[np.float64]],
               in_view: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None) -> _Weighed:
        """Steps 1-2 of the module docstring for every vehicle that scanned: the particles' and the tracks'
        existence after the scan, which tracks were detected and looked at, which detections are free."""
        counts = {"gated": 0, "associated": 0, "clusters": 0, "over": 0, "pairs": 0}
        weighed = _Weighed(clouds, np.zeros(tracks.size, dtype=bool), None,
                           {b.vehicle: np.ones(b.z.shape[0], dtype=bool) for b in batches}, {}, counts)
        if not tracks.size:
            return weighed
        graph, spread2 = self.road_filter.graph, self.road_filter.spread_m**2
        mean, cov = clouds.summary(graph)
        points, log_w = clouds.positions(graph), clouds.log_weights
        xy = points.reshape(log_w.shape + (2,))
        confirmed = tracks.status == Lifecycle.CONFIRMED
        seen = None
        if self.sees is not None and lookers:  # the confirmed tracks' particles; a tentative track's count as seen
            seen = np.ones((len(lookers),) + log_w.shape, dtype=bool)
            rows = np.flatnonzero(confirmed)
            if rows.size:
                picked = xy[rows].reshape(-1, 2)
                seen[:, rows] = self.sees(picked, np.array(list(lookers.values()))).reshape(
                    (len(lookers), rows.size, log_w.shape[1]))
            weighed.looked = looked = np.einsum("tp,tp->t", np.exp(log_w), seen.any(axis=0)) >= 0.5
            if in_view is not None and not confirmed.all():
                weighed.looked = np.where(confirmed, looked, np.asarray(in_view(mean[:, :2]), dtype=bool))
        elif in_view is not None:  # no sight test of the particles: every vehicle covers a track where in_view says
            in_sight = np.asarray(in_view(mean[:, :2]), dtype=bool)
            seen = np.broadcast_to(in_sight[None, :, None], (len(lookers),) + log_w.shape)
            weighed.looked = in_sight
        gate_cov = cov.copy()
        gate_cov[:, [0, 1], [0, 1]] += spread2
        by_vehicle = {b.vehicle: b for b in batches}
        update = np.zeros_like(log_w)
        log_ratio = np.zeros(tracks.size)
        for row, vehicle in enumerate(lookers):
            pd = detection_probabilities(None if seen is None else seen[row], log_w.shape,
                                         self.detection_probability, self.detection_floor)
            batch = by_vehicle.get(vehicle)
            group = None if batch is None else (batch.sensor, batch.z, batch.xyz, batch.pcov)
            terms = particle_terms(xy, log_w, pd, self.gate_probability, group, spread2)
            beta = counted = np.zeros((tracks.size, 0), dtype=bool)
            if batch is not None:
                _, valid = self._gated(mean, gate_cov, batch, counts)
                beta, detected, used = self._beta(costs_of(terms, valid, self.clutter_density), valid, counts)
                counted = valid if self.association == "jpda" else beta > 0.0
                weighed.hit |= detected
                weighed.free[vehicle] = ~used
                weighed.detected_by[vehicle] = tuple(tracks.ids[detected].tolist())
            update += mixture_log_weights(terms, beta) - log_w
            log_ratio += existence_log_ratio(terms, counted, self.clutter_density)
        new_log_w = np.array([normalise_log_weights(row)[0] for row in log_w + update])
        existence = np.where(confirmed, updated_existence(clouds.existence, log_ratio), clouds.existence)
        weighed.clouds = replace(clouds.with_log_weights(new_log_w), existence=existence)
        return weighed

    def _merged(self, tracks: TrackSet, clouds: TrackClouds) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
        """The tracks merged into an older one on this scan, and every track's new count of unresolved scans
        (:mod:`~gcs.core.multitarget.road_merging`)."""
        if self.merge_scans < 1 or tracks.size < 2:
            return np.zeros(tracks.size, dtype=bool), np.zeros(tracks.size, dtype=np.int64)
        pairs = unresolved(clouds, tracks.mean, tracks.cov, len(self.road_filter.graph), self.merge_overlap,
                           gate_threshold(self.merge_probability, 2))
        return merged(tracks, pairs, clouds.unresolved, self.merge_scans)

    def _born(self, batches: Sequence[DetectionBatch], free: Sequence[NDArray[np.bool_]], next_id: int,
              existing: TrackSet, rng: np.random.Generator) -> tuple[TrackSet, TrackClouds]:
        """New tentative tracks and their clouds from the free detections, ids from ``next_id``."""
        p, c = self._new_positions(batches, free, existing)
        mean, cov = initial_states(p, c, self.initial_velocity_std_mps)
        clouds = start_clouds(self.road_filter, mean, cov, self.particles, self.lane_std_m, self.initial_existence, rng)
        if len(p):
            mean, cov = clouds.summary(self.road_filter.graph)
        ids = np.arange(next_id, next_id + p.shape[0], dtype=np.int64)
        return TrackSet.new(ids, mean, cov, confirm_at_once=self.confirm_m <= 1), clouds


@dataclass
class _Weighed:
    """What :meth:`RoadMultiTargetTracker._weigh` gives back (see there)."""

    clouds: TrackClouds
    hit: NDArray[np.bool_]
    looked: NDArray[np.bool_] | None
    free: dict[int, NDArray[np.bool_]]
    detected_by: dict[int, tuple[int, ...]]
    counts: dict[str, int]


def _lookers(batches: Sequence[DetectionBatch], vehicles: Mapping[int, NDArray[np.float64]] | None
             ) -> dict[int, NDArray[np.float64]]:
    """Every vehicle that scanned, by index in increasing order, and where it was."""
    where = {int(k): np.asarray(v, dtype=np.float64).reshape(3) for k, v in (vehicles or {}).items()}
    for batch in batches:
        where.setdefault(batch.vehicle, batch.xyz[0])
    return dict(sorted(where.items()))
