"""``gcs-bench sharing``: UAVs shared between several targets, closed loop.

**Scene per seed**: the truths of :func:`benchmarks.multitarget.make_scene` (``targets``
street-following targets on the wang2012_urban city, a side-by-side pair among them),
every draw from ``numpy.random.default_rng(seed)``; the UAVs start where that bench's
fixed orbits start (:data:`~benchmarks.multitarget.ORBITS`), at the scenario's altitudes,
speeds and turn limits.

**Loop**, one decision step a second: each UAV scans (line of sight past the
buildings, range, ``pd`` and Poisson clutter: :func:`sim_vehicles.truth.detections.scan`,
its draws from ``default_rng([seed, 1])``); our JPDA tracker
(:class:`gcs.core.multitarget.MultiTargetTracker`) takes the scan; each confirmed
track is predicted over the planner's horizon (the constant-velocity model of
wang2012 eq. 16-17, :meth:`~gcs.core.models.motion.LinearMotionModel.horizon_matrices`),
and the team plan is made by one of the **modes**:

* ``sum``: the sight objective summed over the tracks with priority weights that grow with the
  time a track has gone without a detection
  (:meth:`~gcs.core.planners.sequential.SightPlanner.solve_shared`);
* ``assign``: each UAV assigned one track, then each track planned for with its own UAVs
  (:meth:`~gcs.core.planners.sequential.SightPlanner.solve_assigned`);
* ``orbit``: no planner, each UAV keeps its fixed orbit (the baseline of ``gcs-bench multitarget``).

The planned modes plan for the confirmed tracks and for the lost targets
(:class:`gcs.core.multitarget.lost.LostTargets`: confirmed tracks the tracker deleted,
predicted on, searched for :data:`FORGET_S`), each weighted by the time it has gone
without a detection. With nothing to plan for, a UAV steers back toward its home orbit. The UAVs fly
the first step of the plan with the kinematics of wang2012 eq. (1) (the ideal
airframe). The planner's draws come from ``default_rng([seed, 2])``.

**Scores** per run, over the steps after the warm-up (all but the last, in a run no longer than it): for each target, the steps in
which some UAV has it in its field (in range and in sight, before ``pd``); their mean
and their minimum over the targets (a starved target shows in the minimum); for each
UAV, the steps in which it has some target in its field; the mean GOSPA of the
confirmed tracks (:data:`~benchmarks.multitarget.CUTOFF_M`, p = 2, alpha = 2); and the
median planning time.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from benchmarks import multitarget as mt
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout
from gcs.core.metrics import gospa
from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget import MultiTargetTracker
from gcs.core.multitarget.lost import LostTargets
from gcs.core.multitarget.planning import problems_for, targets_to_plan
from gcs.core.planners.baselines import orbit_heading
from gcs.core.tracker import TrackerConfig
from gcs.core.world import World
from sim_vehicles.truth.detections import scan as detection_scan

__all__ = ["MODES", "STARVATION_S", "SharingConfig", "SharingRun", "fly_run"]

MODES = ("sum", "assign", "orbit")
STARVATION_S = 20.0
"""``tau`` of :func:`gcs.core.planners.shared.target_weights`: an unseen track's claim doubles in 20 s."""
FORGET_S = 90.0
"""A lost target (:class:`gcs.core.multitarget.lost.LostTargets`) is searched for this long."""
FOUND_GATE = 13.8
"""Chi-square gate (2 degrees of freedom, 0.999) by which a confirmed track finds a lost target again."""


@dataclass(frozen=True)
class SharingConfig:
    """One run: the scene (:class:`benchmarks.multitarget.BenchConfig`) and the planner's starvation time."""

    scene: mt.BenchConfig = mt.BenchConfig()
    starvation_s: float = STARVATION_S


@dataclass(frozen=True)
class SharingRun:
    """One mode over one run (module docstring): per target and per UAV in-field steps, GOSPA, planning times."""

    target_steps: NDArray[np.int64]
    uav_steps: NDArray[np.int64]
    gospa_m: float
    plan_seconds: tuple[float, ...]
    decision_seconds: tuple[float, ...] = ()
    """Per step, the tracker's scan and the plan (if one was made) together (``time.perf_counter``)."""
    scan_seconds: tuple[float, ...] = ()
    """The tracker's time per scan."""
    detections: int = 0
    """Detections the tracker took over the run, clutter included."""


def _home_turns(vehicles: VehicleState, eta: NDArray[np.float64], step_s: float) -> NDArray[np.float64]:
    """Turn rates (V,) toward each UAV's home orbit (counter-clockwise, the tangent tilted by atan((d - r) / r))."""
    orbits = np.array(mt.orbits(len(vehicles)))
    desired = orbit_heading(vehicles.xy, orbits[:, :2], orbits[:, 2])
    return np.clip(wrap_angle(desired - vehicles.heading) / step_s, -eta, eta)


def _start(scene: mt.Scene, speeds: NDArray[np.float64]) -> VehicleState:
    """The UAVs where the fixed orbits put them at step 0, heading along the orbit."""
    xyz, ahead = scene.vehicle_xyz[0], scene.vehicle_xyz[1]
    heading = np.arctan2(ahead[:, 1] - xyz[:, 1], ahead[:, 0] - xyz[:, 0])
    return VehicleState(xyz[:, :2].copy(), heading, speeds, xyz[:, 2].copy())


def fly_run(mode: str, world: World, config: TrackerConfig, speeds: NDArray[np.float64],
            altitudes: NDArray[np.float64], seed: int, sharing: SharingConfig) -> SharingRun:
    """One run of ``mode`` on seed ``seed`` (module docstring), UAVs at ``speeds`` (m/s) and ``altitudes`` (m)."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; expected one of {', '.join(MODES)}")
    bench = sharing.scene
    scene = mt.make_scene(world, list(altitudes), bench, np.random.default_rng(seed))
    scan_rng, plan_rng = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
    sensor = config.sensors[0]
    max_range = config.max_range_m
    motion = constant_velocity(mt.PROCESS_NOISE)
    tracker = MultiTargetTracker(association="jpda", motion=motion, detection_probability=bench.pd,
                                 max_misses=mt.MAX_MISSED_SCANS,
                                 clutter_density=max(bench.clutter, 1e-3) / mt.clutter_volume(max_range))
    state, lost = tracker.start(), LostTargets.none()
    confirmed_ids: set[int] = set()
    vehicles = _start(scene, speeds)
    turn_rate, plan = np.zeros(len(speeds)), None
    steps = len(scene.truth_xy)
    scored_from = min(bench.warm_up, steps - 1)
    target_steps, uav_steps = np.zeros(bench.targets, dtype=np.int64), np.zeros(len(speeds), dtype=np.int64)
    gospas, plan_seconds, scan_seconds, decision_seconds, detections = [], [], [], [], 0
    for k in range(steps):
        xyz = (scene.vehicle_xyz[k] if mode == "orbit"
               else np.column_stack([vehicles.xy, vehicles.altitude]))
        truths = scene.truth_xy[k]
        field = mt.in_field(world, truths, xyz, sensor.target_height_m, max_range)
        result = detection_scan(truths, xyz, sensor, bench.pd, bench.clutter, max_range, scan_rng, field)
        started = time.perf_counter()
        state, diagnostics = tracker.scan(state, k * mt.STEP_NS, dict(enumerate(result.detections)), sensor)
        scan_seconds.append(time.perf_counter() - started)
        decision_seconds.append(scan_seconds[-1])
        detections += diagnostics.detections
        confirmed = state.tracks.confirmed()
        deleted = diagnostics.deleted
        lost = lost.advance(motion, config.step_s)
        lost = lost.add(deleted, np.isin(deleted.ids, list(confirmed_ids)), config.step_s)
        lost = lost.forget(confirmed, FOUND_GATE, FORGET_S)
        confirmed_ids = set(int(i) for i in confirmed.ids)
        if k >= scored_from:
            target_steps += field.any(axis=0)
            uav_steps += field.any(axis=1)
            gospas.append(gospa(confirmed.mean[:, :2], truths, mt.CUTOFF_M, mt.ORDER_P).distance)
        if mode == "orbit" or k == steps - 1:
            continue
        means, covs = np.concatenate([confirmed.mean, lost.mean]), np.concatenate([confirmed.cov, lost.cov])
        unseen = np.concatenate([confirmed.misses * config.step_s, lost.unseen_s])
        if len(means) == 0:
            turn_rate, plan = _home_turns(vehicles, config.max_turn_rate, config.step_s), None
        else:
            targets = targets_to_plan(tuple(map(str, range(len(means)))), means, covs, unseen, motion,
                                      config.step_s, config.horizon_steps, sharing.starvation_s)
            problems = problems_for(config, vehicles, turn_rate, targets.means, targets.covs)
            weights = targets.weights
            solve = config.planner.solve_shared if mode == "sum" else config.planner.solve_assigned
            started = time.perf_counter()
            outcome = solve(problems, weights, plan_rng, plan)
            plan_seconds.append(time.perf_counter() - started)
            decision_seconds[-1] += plan_seconds[-1]
            plan = config.guard.safe(vehicles, outcome.controls, config.step_s, config.max_turn_rate)
            turn_rate = plan[:, 0].copy()
        xy, heading = rollout(vehicles, turn_rate[:, None], config.step_s, config.max_turn_rate)
        vehicles = VehicleState(xy[:, 0], heading[:, 0], vehicles.speed, vehicles.altitude)
    return SharingRun(target_steps, uav_steps, float(np.mean(gospas)) if gospas else math.nan, tuple(plan_seconds),
                      tuple(decision_seconds), tuple(scan_seconds), detections)

