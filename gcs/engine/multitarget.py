"""The engine's many-target tracking (a scenario's ``[multitarget]``): scans, tracks on the wire, what to plan for.

:class:`TrackKeeper` holds the multi-target tracker's state between decision steps. Each
released step's detections, every vehicle's and none with an identity
(:func:`gcs.engine.fusion.scan_detections`), are one scan of
:class:`gcs.core.multitarget.MultiTargetTracker`, with the coverage of the vehicles that
reported in it (in range, the smallest of the vehicles' sensor ranges, and in sight
past the buildings, :func:`gcs.core.multitarget.coverage.coverage`; with no world, every
track counts as covered). Every confirmed track is published as a ``TrackEstimate`` named ``t<id>``
(its id never reused) with its k+1..k+n prediction; a confirmed track that the tracker
deletes becomes a lost target, searched for ``forget_s`` (:class:`gcs.core.multitarget.lost.LostTargets`).
The planner is given the confirmed tracks and the lost targets
(:mod:`gcs.core.multitarget.planning`).

The tracker is the one ``[multitarget] kind`` names (:func:`gcs.config.multitarget.multitarget_kind`; by
default the road tracker wherever the world has a road graph): :func:`many_target_tracker` builds it,
for the daemon and replay alike. The road tracker (:class:`~gcs.core.multitarget.road_tracker.RoadMultiTargetTracker`)
moves its particles as ``[estimator.road]`` says (:func:`gcs.engine.tracker_factory.road_tracking`: the
same motion, sight table and seed as the single-target road tracker), and is told where every vehicle
that reported was, those that detected nothing included (their negative information).

The tracker's detection probability and clutter are the scenario's sensor's
(``detection_probability``; ``clutter_rate`` false detections per scan spread over the
measurement volume of :func:`~gcs.core.multitarget.coverage.clutter_volume`, at least
1e-3 per scan so that a clutter-free scenario still allows for an odd false alarm).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.federation import OwnTracks
from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget import MultiTargetState, MultiTargetTracker, ScanDiagnostics, TrackSet
from gcs.core.multitarget.coverage import clutter_volume, coverage
from gcs.core.multitarget.gating import gate_threshold
from gcs.core.multitarget.lost import LostTargets
from gcs.core.multitarget.planning import TargetsToPlan, targets_to_plan
from gcs.core.multitarget.road_tracker import RoadMultiTargetTracker
from gcs.core.target_tracker import TargetTracker
from gcs.core.tracker import TrackerConfig
from gcs.core.world import World
from gcs.engine.fusion import scan_detections, track_message
from gcs.engine.navigation import FleetNavigator
from gcs.engine.steps import ReadyStep
from gcs.engine.tracker_factory import road_tracking
from protocols.messages import TrackEstimate

__all__ = ["TrackKeeper", "Scanned", "MIN_CLUTTER_PER_SCAN", "FOUND_PROBABILITY", "track_name", "many_target_tracker"]

NS_PER_S = 1_000_000_000
MIN_CLUTTER_PER_SCAN = 1e-3
FOUND_PROBABILITY = 0.999
"""A lost target is found again when a confirmed track lies inside its gate of this probability (2 dof)."""
MODEL = "cv2d"


def _covers_nothing(points_xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The coverage of a step in which no vehicle reported."""
    return np.zeros(len(points_xy), dtype=bool)


def track_name(track_id: int) -> str:
    """The wire id of a multi-target track: ``t<id>``."""
    return f"t{int(track_id)}"


@dataclass(frozen=True)
class Scanned:
    """One step's scan: the confirmed tracks' messages, and per roster vehicle whether it detected one."""

    tracks: tuple[TrackEstimate, ...]
    detected: dict[str, bool]
    diagnostics: ScanDiagnostics


def many_target_tracker(scenario: Scenario, world: World | None, tracker: TrackerConfig) -> MultiTargetTracker:
    """The scenario's many-target tracker (module docstring): the road tracker or the Gaussian one, with the
    ``[multitarget]`` association, lifecycle and motion, and the sensor's detection probability and clutter.
    ``auto`` without a world (estimation only, every track covered) is the Gaussian tracker. ValueError for a
    scenario without ``[multitarget]``, or ``kind = "road"`` without a world with roads."""
    config = scenario.multitarget
    if config is None:
        raise ValueError(f"scenario {scenario.name!r} has no [multitarget] table")
    clutter = max(scenario.sensor.clutter_rate, MIN_CLUTTER_PER_SCAN) / clutter_volume(tracker.max_range_m)
    common: dict[str, Any] = dict(
        association=config.association, motion=constant_velocity(config.accel_psd_m2_s3),
        detection_probability=scenario.sensor.detection_probability, gate_probability=config.gate_probability,
        clutter_density=clutter, confirm_m=config.confirm_m, confirm_n=config.confirm_n,
        max_misses=config.max_misses, max_position_trace_m2=config.max_position_trace_m2,
        initial_velocity_std_mps=config.initial_velocity_std_mps)
    if config.kind == "gaussian" or (config.kind == "auto" and (world is None or world.roads is None)):
        return MultiTargetTracker(**common)
    roads = road_tracking(scenario, world)
    return RoadMultiTargetTracker(roads=roads.filter, sees=roads.sees, particles=config.road_particles,
                                  seed=roads.seed, **common)


class TrackKeeper:
    """The multi-target tracker's memory between steps; see the module docstring."""

    def __init__(self, scenario: Scenario, world: World | None, tracker: TrackerConfig) -> None:
        config = scenario.multitarget
        if config is None:
            raise ValueError(f"scenario {scenario.name!r} has no [multitarget] table")
        self.config, self.world, self.tracker_config = config, world, tracker
        self.motion = constant_velocity(config.accel_psd_m2_s3)
        built = many_target_tracker(scenario, world, tracker)
        self.tracker: TargetTracker[MultiTargetState, ScanDiagnostics] = built
        self.road = built if isinstance(built, RoadMultiTargetTracker) else None
        self.state: MultiTargetState = self.tracker.start()
        self.lost = LostTargets.none()
        self._confirmed_ids: set[int] = set()
        self._detected_ns: dict[int, int] = {}
        """Stamp of each live track's newest detection (its birth counts)."""
        self._targets: TargetsToPlan | None = None

    def scan(self, ready: ReadyStep, roster: Sequence[str], config: TrackerConfig, seq: int,
             navigator: FleetNavigator | None = None) -> Scanned:
        """Take one released step (every roster vehicle's first report in it); the tracks to publish, seq ``seq``."""
        detections, positions = scan_detections(ready, roster, config.sensors, navigator)
        in_view = None  # without a world: every track counts as covered
        if self.world is not None:
            in_view = (coverage(self.world, positions, config.sensors[0].target_height_m, config.max_range_m)
                       if len(positions) else _covers_nothing)
        before = self.state.stamp_ns
        if self.road is not None:  # every vehicle that reported, by roster index: where it was
            reported = {r.vehicle_id for r in ready.reports}
            indices = [i for i, vehicle in enumerate(roster) if vehicle in reported]
            self.state, diagnostics = self.road.scan(self.state, ready.stamp_ns, detections, config.sensors, in_view,
                                                     dict(zip(indices, positions)))
        else:
            self.state, diagnostics = self.tracker.scan(self.state, ready.stamp_ns, detections, config.sensors,
                                                        in_view)
        confirmed = self.state.tracks.confirmed()
        if before is not None and ready.stamp_ns > before:
            self.lost = self.lost.advance(self.motion, (ready.stamp_ns - before) / NS_PER_S)
        for track_id in diagnostics.initiated_ids + tuple(i for ids in diagnostics.detected_by.values() for i in ids):
            self._detected_ns[track_id] = ready.stamp_ns
        deleted = diagnostics.deleted
        self.lost = self.lost.add(deleted, np.isin(deleted.ids, list(self._confirmed_ids)), config.step_s,
                                  self._unseen_s(deleted.ids, ready.stamp_ns))
        self.lost = self.lost.forget(confirmed, gate_threshold(FOUND_PROBABILITY, 2), self.config.forget_s)
        self._confirmed_ids = {int(i) for i in confirmed.ids}
        for track_id in deleted.ids.tolist():
            self._detected_ns.pop(track_id, None)
        contributing: dict[int, list[str]] = {int(i): [] for i in confirmed.ids}
        detected = {v: False for v in roster}
        for index, ids in sorted(diagnostics.detected_by.items()):
            for track_id in ids:
                if track_id in contributing:
                    contributing[track_id].append(roster[index])
                    detected[roster[index]] = True
        self._targets = plan = self._to_plan(confirmed, ready.stamp_ns)  # the confirmed tracks' rows first
        messages = []
        if plan is not None:  # None only without a confirmed track or a lost target
            for row, track_id in enumerate(confirmed.ids.tolist()):
                estimate = GaussianEstimate(confirmed.mean[row], confirmed.cov[row], ready.stamp_ns)
                messages.append(track_message(config, estimate, track_name(track_id), MODEL, seq,
                                              contributing[track_id], self._prediction(plan, row, ready.stamp_ns)))
        return Scanned(tuple(messages), detected, diagnostics)

    def own_tracks(self) -> OwnTracks:
        """The confirmed tracks of the newest scan, with the stamp of each one's newest detection (for a federation)."""
        confirmed = self.state.tracks.confirmed()
        detected = np.array([self._detected_ns.get(int(i), 0) for i in confirmed.ids], dtype=np.int64)
        return OwnTracks(confirmed.ids.astype(np.int64), confirmed.mean, confirmed.cov, detected)

    def targets(self) -> TargetsToPlan | None:
        """The newest scan's confirmed tracks and lost targets to plan for, weighted by the time each has gone
        unseen (:func:`gcs.core.planners.shared.target_weights`); None when there are none."""
        return self._targets

    def _to_plan(self, confirmed: TrackSet, stamp_ns: int) -> TargetsToPlan | None:
        """The confirmed tracks and the lost targets at ``stamp_ns`` (the scan's), predicted over the horizon and
        weighted."""
        lost = self.lost
        if confirmed.size + lost.size == 0:
            return None
        ids = np.concatenate([confirmed.ids, lost.ids])
        unseen = np.concatenate([self._unseen_s(confirmed.ids, stamp_ns), lost.unseen_s])
        config = self.tracker_config
        return targets_to_plan(tuple(track_name(i) for i in ids), np.concatenate([confirmed.mean, lost.mean]),
                               np.concatenate([confirmed.cov, lost.cov]), unseen, self.motion, config.step_s,
                               config.horizon_steps, self.config.starvation_s, config.predict_ahead)

    def _unseen_s(self, ids: NDArray[np.int64], stamp_ns: int) -> NDArray[np.float64]:
        """Seconds since each track (ids) last had a detection, at ``stamp_ns``, whether or not a sensor covered it."""
        return np.array([(stamp_ns - self._detected_ns.get(int(i), stamp_ns)) / NS_PER_S for i in ids], dtype=float)

    def _prediction(self, plan: TargetsToPlan, row: int, stamp_ns: int) -> HorizonPrediction:
        """Track ``row``'s k+1..k+n prediction as the single-target track carries it."""
        step_ns = round(self.tracker_config.step_s * NS_PER_S)
        steps = plan.means.shape[1]
        stamps = tuple(stamp_ns + (j + 1) * step_ns for j in range(steps))
        return HorizonPrediction(stamps, GaussianEstimate(plan.means[row], plan.covs[row], stamps[0]))
