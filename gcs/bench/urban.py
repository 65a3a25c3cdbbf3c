"""The wang2012 section 5 experiment as a closed loop in one process, with no I/O.

Each 1 s step (the ASRTP loop): the truth target moves; the UAVs fly the
command chosen at the previous step (eq. 1); every UAV senses the target unless
a building blocks the line of sight or it is out of range
(:mod:`sim_vehicles.truth.sensor`); the tracker fuses the detections
(:func:`gcs.core.tracker.fuse`; the road tracker also the UAVs that saw nothing), then predicts and plans
(:func:`gcs.core.tracker.plan`) the next commands.

Planners compared over paired runs (same seed: same city, same target path,
same sensor noise draws): any of :data:`gcs.core.planner_names.URBAN_PLANNERS`, e.g.

* ``sight``: the sight objective on the k+1..k+n predictions (the default planner);
* ``sight_k0``: the same on the current estimate held over the horizon;
* ``ga_k5``: GA-RHC on the k+1..k+5 predictions (the paper's method);
* ``ga_k0``: GA-RHC on the current estimate held over the horizon (the paper's k+0);
* ``orbit``: stand-off orbit around the estimate;
* ``pursuit``: fly straight at the estimate.

Recorded per step: which UAVs saw the target, the fused position error, the
decision time (the whole planning step: prediction, sight tables or visibility
maps, search and the airspace guard; wall clock), and which UAVs were inside
restricted airspace at any of ``VIOLATION_SAMPLES`` points of the arc they
flew. Planners run to their full budget with no deadline, so a run's result
depends on its seed alone, not on the machine or on what else runs beside it.

This loop does not drive the daemon's engine (:mod:`gcs.engine`, which ``gcs bench
autopilots`` does): it is the paper's experiment on the true kinematics, every UAV
flying its planned turn rate exactly (eq. 1) and every detection made in process, so
there are no reports to validate, no steps to assemble and no autopilot to steer; going
through report decoding and step release would add the wire and the ground station's
timing to what is a measurement of the estimator and the planners against wang2012.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import msgspec

import numpy as np
from numpy.typing import NDArray

from gcs.bench.urban_nav import FleetNavigation
from gcs.config import Scenario
from gcs.core.filters.uif import NS_PER_S
from gcs.core.kinematics import VehicleState, rollout, step_vehicles
from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection, Sensing, TrackerState, fuse, plan
from gcs.core.world import World
from gcs.engine.tracker_factory import FROM_SCENARIO, filter_sensor_models, tracker_config
from gcs.core.planner_names import URBAN_PLANNERS as PLANNERS
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import start_state, target_model

__all__ = ["PLANNERS", "LOST_M", "VIOLATION_SAMPLES", "RunRecord", "run_closed_loop", "sensor_models", "tracker_config",
           "with_vehicles"]

LOST_M = 100.0
"""A run *lost the track* when the fused estimate was ever farther than this from the target."""
VIOLATION_SAMPLES = 5
"""Points of each flown 1 s arc tested against restricted airspace."""


@dataclass(frozen=True)
class RunRecord:
    """Everything one closed-loop run produced, step by step (K steps, V vehicles)."""

    planner: str
    seed: int
    seen: NDArray[np.bool_]  # (K, V)
    errors_m: NDArray[np.float64]  # (K,) position error, NaN before the track starts
    decision_s: NDArray[np.float64]  # (K,) planner solve time, NaN when it did not run
    vehicle_xy: NDArray[np.float64]  # (K, V, 2)
    target_xy: NDArray[np.float64]  # (K, 2)
    estimate_xy: NDArray[np.float64]  # (K, 2)
    violations: NDArray[np.bool_] | None = None  # (K, V) inside restricted airspace during the step
    navigation: str = "perfect"
    nav_error_m: NDArray[np.float64] | None = None  # (K, V) the vehicles' own position error, with navigation
    gps_fix: NDArray[np.bool_] | None = None  # (K, V) whether each vehicle had a GPS fix, with navigation

    @property
    def seen_any(self) -> int:
        """Steps at which at least one UAV saw the target."""
        return int(self.seen.any(axis=1).sum())

    @property
    def seen_per_uav(self) -> list[int]:
        """Steps at which each UAV saw the target."""
        return [int(n) for n in self.seen.sum(axis=0)]

    @property
    def violation_steps(self) -> int:
        """Vehicle-steps spent (partly) inside restricted airspace."""
        return 0 if self.violations is None else int(self.violations.sum())

    @property
    def lost(self) -> bool:
        """Whether the fused estimate was ever farther than :data:`LOST_M` from the target."""
        valid = np.isfinite(self.errors_m)
        return bool(valid.any() and self.errors_m[valid].max() > LOST_M)

    @property
    def rmse_m(self) -> float:
        """Fused position RMSE over the steps with a track."""
        valid = np.isfinite(self.errors_m)
        return float(np.sqrt(np.mean(self.errors_m[valid] ** 2))) if valid.any() else float("nan")


def sensor_models(scenario: Scenario) -> tuple[tuple[SensorModel, ...], tuple[TargetSensor, ...]]:
    """The filter's sensor model and the truth sensor of every vehicle, from the scenario."""
    truths = tuple(TargetSensor.from_config(scenario.sensor_for(v)) for v in scenario.vehicles)
    return filter_sensor_models(scenario), truths


def run_closed_loop(
    scenario: Scenario,
    world: World,
    planner: str,
    seed: int,
    duration_s: float | None = None,
    motion: str | None = None,
    generations: int | None = None,
    stall: int | None | str = FROM_SCENARIO,
    clock: Callable[[], float] | None = time.perf_counter,
    navigation: str | None = None,
) -> RunRecord:
    """One closed-loop run. ``clock`` times each planning step (never the planner's deadline); None: no timing.

    ``generations`` and ``stall`` override the scenario's GA budget (``stall=None``: no early stop).
    ``navigation`` (one of :data:`gcs.bench.urban_nav.NAVIGATION_MODES`) gives the tracker and planner
    the vehicles' own navigation instead of their true positions (:mod:`gcs.bench.urban_nav`).
    """
    dt = scenario.time.step_s
    steps = int(round((duration_s or scenario.time.duration_s) / dt))
    truth_rng = np.random.default_rng([seed, 1])
    sensor_rng = np.random.default_rng([seed, 2])
    plan_rng = np.random.default_rng([seed, 3])
    config = tracker_config(scenario, world, planner, generations, stall)
    if config.road is not None:  # the road tracker's draws: the run's own, seeded by the run's seed
        config = replace(config, road=replace(config.road, seed=seed))
    _, truth_sensors = sensor_models(scenario)
    model = target_model(scenario, world, motion)
    target = start_state(model, scenario, truth_rng)
    vehicles = VehicleState(
        np.array([v.start_enu_m for v in scenario.vehicles], dtype=np.float64),
        np.array([v.start_heading_rad for v in scenario.vehicles]),
        np.array([v.speed_mps for v in scenario.vehicles]),
        np.array([v.altitude_m for v in scenario.vehicles]),
    )
    state = TrackerState.start(len(vehicles))
    count = len(vehicles)
    seen = np.zeros((steps, count), dtype=bool)
    errors, decisions = np.full(steps, np.nan), np.full(steps, np.nan)
    vehicle_xy, target_xy, estimate_xy = np.zeros((steps, count, 2)), np.zeros((steps, 2)), np.full((steps, 2), np.nan)
    nav = None if navigation is None else FleetNavigation.start(navigation, scenario, seed, vehicles)
    nav_error, gps_fix = np.zeros((steps, count)), np.ones((steps, count), dtype=bool)
    airspace = len(world.airspace) > 0
    violations = np.zeros((steps, count), dtype=bool)
    for k in range(steps):
        stamp_ns = int(round(k * dt * NS_PER_S))
        if k > 0:
            target = model.step(target, dt, truth_rng)
            before = vehicles
            vehicles = step_vehicles(vehicles, state.turn_rate, dt, config.max_turn_rate)
            if nav is not None:
                nav.fly(before, vehicles, dt, stamp_ns)
        believed = vehicles if nav is None else nav.believed(vehicles)
        target_xyz = np.array([target.position[0], target.position[1], 0.0])
        detections = []
        for i, sensor in enumerate(truth_sensors):
            obs = sensor.observe(target_xyz, vehicles.xyz[i : i + 1], world.line_of_sight, sensor_rng)
            if obs.detected[0]:
                detections.append(Detection(i, believed.xyz[i], obs.values[0],
                                            None if nav is None else nav.covariance(i)))
                seen[k, i] = True
        estimate = fuse(config, state.estimate, stamp_ns, detections, Sensing(believed.xyz, seen[k].copy()))
        started = clock() if clock is not None else 0.0
        state, _, diagnostics = plan(config, replace(state, estimate=estimate), believed, plan_rng)
        if diagnostics.plan is not None and clock is not None:
            decisions[k] = clock() - started
        if nav is not None:
            nav.commanded(believed, state.plan if state.plan is not None else state.turn_rate[:, None], dt,
                          config.max_turn_rate)
            nav_error[k], gps_fix[k] = nav.errors_m(vehicles), nav.fixes
        if airspace:
            violations[k] = _inside_airspace(world, vehicles, state.turn_rate, dt, config.max_turn_rate)
        if state.estimate is not None:
            estimate_xy[k] = state.estimate.mean[:2]
            errors[k] = float(np.hypot(*(state.estimate.mean[:2] - target.position)))
        vehicle_xy[k], target_xy[k] = vehicles.xy, target.position
    if nav is None:
        return RunRecord(planner, seed, seen, errors, decisions, vehicle_xy, target_xy, estimate_xy, violations)
    return RunRecord(planner, seed, seen, errors, decisions, vehicle_xy, target_xy, estimate_xy, violations,
                     navigation, nav_error, gps_fix)


def _inside_airspace(world: World, vehicles: VehicleState, turn_rate: NDArray[np.float64], dt: float,
                     max_turn_rate: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which vehicles (V,) will be inside restricted airspace at any of :data:`VIOLATION_SAMPLES` points of the
    arc they fly next, holding ``turn_rate`` for ``dt``."""
    xy, _ = rollout(vehicles, np.broadcast_to(turn_rate[:, None], (len(vehicles), VIOLATION_SAMPLES)),
                    dt / VIOLATION_SAMPLES, max_turn_rate, headings=False)
    xyz = np.concatenate([xy, np.broadcast_to(vehicles.altitude[:, None, None], xy.shape[:-1] + (1,))], axis=-1)
    return world.in_restricted(xyz).any(axis=-1)


def with_vehicles(scenario: Scenario, count: int) -> Scenario:
    """The scenario with ``count`` UAVs: the originals, then more spread on a ring around the target's start."""
    vehicles = list(scenario.vehicles[:count])
    cx, cy = scenario.target.start_enu_m
    base = vehicles[0]
    for i in range(len(vehicles), count):
        angle = 2.0 * np.pi * i / count
        vehicles.append(msgspec.structs.replace(base, id=f"uav{i + 1}", sysid=i + 1, altitude_m=base.altitude_m + 10.0 * i,
                                start_enu_m=(cx + 400.0 * np.cos(angle), cy + 400.0 * np.sin(angle)),
                                start_heading_rad=float(np.remainder(angle + np.pi, 2 * np.pi) - np.pi)))
    return msgspec.structs.replace(scenario, vehicles=vehicles)
