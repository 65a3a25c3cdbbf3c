"""The wang2012 section 5 experiment as a closed loop in one process, through the ground station's engine.

Each run flies :mod:`benchmarks.closed_loop`: the simulated scene of :mod:`benchmarks.urban_scene` (the
truth target, occluded sensing from the true vehicle positions, what the vehicles report) feeds the
daemon's engine (:class:`gcs.engine.engine.Engine`: acceptance, step assembly, fusion, the k+1..k+n
prediction, plan jobs), every plan is made at once with no deadline, and the vehicles fly its turn
rates (wang2012 eq. 1). Planners compared over paired runs (same seed: same city, same target path,
same sensor noise draws): any of :data:`gcs.core.planner_names.URBAN_PLANNERS`, e.g.

* ``sight``: the sight objective on the k+1..k+n predictions (the default planner);
* ``sight_k0``: the same on the current estimate held over the horizon;
* ``ga_k5``: GA-RHC on the k+1..k+5 predictions (the paper's method);
* ``ga_k0``: GA-RHC on the current estimate held over the horizon (the paper's k+0);
* ``orbit``: stand-off orbit around the estimate;
* ``pursuit``: fly straight at the estimate.

Recorded per decision step: which UAVs saw the target (the engine's step records), the published
track's position and covariance and its error against the truth (the point estimate scored is the
position of the ``TrackEstimate`` the engine publishes for the step, the tracker's posterior mean at
the step's stamp), the decision time (the plan job: sight tables or visibility maps, search and the
airspace guard; wall clock, never the planner's deadline), and which UAVs were inside restricted
airspace at any tick of the step's flight. A run's result depends on its seed alone, not on the
machine, the process or what else runs beside it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import msgspec
import numpy as np
from numpy.typing import NDArray

from benchmarks.closed_loop import IN_PROCESS, EngineLoop, IdealAirframes, fly_step
from benchmarks.urban_scene import NAVIGATIONS, UrbanScene, start_of
from gcs.config import Scenario
from gcs.core.planner_names import URBAN_PLANNERS as PLANNERS
from gcs.core.world import World
from gcs.engine.tracker_factory import FROM_SCENARIO

__all__ = ["PLANNERS", "LOST_M", "RunRecord", "run_closed_loop", "with_vehicles", "with_budget"]

LOST_M = 100.0
"""A run *lost the track* when the fused estimate was ever farther than this from the target."""


@dataclass(frozen=True)
class RunRecord:
    """Everything one closed-loop run produced, step by step (K steps, V vehicles)."""

    planner: str
    seed: int
    seen: NDArray[np.bool_]  # (K, V)
    errors_m: NDArray[np.float64]  # (K,) position error, NaN before the track starts
    decision_s: NDArray[np.float64]  # (K,) the plan job's wall time, NaN when the step was not planned
    vehicle_xy: NDArray[np.float64]  # (K, V, 2)
    target_xy: NDArray[np.float64]  # (K, 2)
    estimate_xy: NDArray[np.float64]  # (K, 2)
    violations: NDArray[np.bool_] | None = None  # (K, V) inside restricted airspace during the step
    nees: NDArray[np.float64] | None = None  # (K,) the track's position NEES, e^T P_pp^-1 e, NaN without a track
    navigation: str = "perfect"
    nav_error_m: NDArray[np.float64] | None = None  # (K, V) the vehicles' own position error, with navigation
    gps_fix: NDArray[np.bool_] | None = None  # (K, V) whether each vehicle had a GPS fix, with navigation
    heading: NDArray[np.float64] | None = None  # (K, V) the vehicles' headings at each step's stamp
    planned_turn_rate: NDArray[np.float64] | None = None  # (K, V) each step's plan's first turn rate, NaN unplanned
    counters: dict[str, int] | None = None  # the engine's counters at the end of the run

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


def with_budget(scenario: Scenario, generations: int | None = None, stall: int | None | str = FROM_SCENARIO
                ) -> Scenario:
    """The scenario with the GA's budget changed: ``generations``, and ``stall`` generations without improvement
    before it stops (None: never; ``"scenario"``: the scenario's)."""
    planner = scenario.planner
    if generations is not None:
        planner = msgspec.structs.replace(planner, generations=generations)
    if stall != FROM_SCENARIO:
        planner = msgspec.structs.replace(planner, stall_generations=stall)
    return scenario if planner is scenario.planner else msgspec.structs.replace(scenario, planner=planner)


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
    """One closed-loop run (:class:`ClosedLoopRun`, every step in turn)."""
    run = ClosedLoopRun(scenario, world, planner, seed, duration_s, motion, generations, stall, clock, navigation)
    for k in range(run.steps):
        run.step(k)
    return run.record()


class ClosedLoopRun:
    """One closed-loop run, stepped by the caller: :meth:`step` for k = 0 .. ``steps`` - 1, then :meth:`record`.

    ``clock`` times each plan job (never the planner's deadline); None: no timing.
    ``generations`` and ``stall`` override the scenario's GA budget (``stall=None``: no early stop).
    ``navigation`` (one of :data:`benchmarks.urban_scene.NAVIGATIONS`; None: ``perfect``) is what the
    vehicles report of their own positions and which navigation the engine runs on it.
    """

    def __init__(self, scenario: Scenario, world: World, planner: str, seed: int, duration_s: float | None = None,
                 motion: str | None = None, generations: int | None = None, stall: int | None | str = FROM_SCENARIO,
                 clock: Callable[[], float] | None = time.perf_counter, navigation: str | None = None) -> None:
        scenario = with_budget(scenario, generations, stall)
        # the road tracker's draws are the run's own: seeded by the run's seed (and each step's stamp)
        road = msgspec.structs.replace(scenario.estimator.road, seed=seed)
        scenario = msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(scenario.estimator, road=road))
        self.nav = navigation or "perfect"
        if self.nav not in NAVIGATIONS:
            raise ValueError(f"unknown navigation {self.nav!r}; expected one of {', '.join(NAVIGATIONS)}")
        self.planner, self.seed, self.dt = planner, seed, scenario.time.step_s
        self.steps = int(round((duration_s or scenario.time.duration_s) / self.dt))
        options = replace(IN_PROCESS, planner=planner, navigation="skf" if self.nav == "skf" else "reported")
        self.loop = EngineLoop(scenario, world, np.random.default_rng([seed, 3]), options, clock=clock)
        self.scene = UrbanScene(scenario, world, seed, self.steps, motion, self.nav)
        self.airframes = IdealAirframes(self.scene.roster, start_of(scenario), self.loop.engine.tracker.max_turn_rate,
                                        self.dt, scenario.simulation.airframe.loiter_radius_m)
        self.navigated = np.full((self.steps, len(self.scene.roster)), np.nan)
        self.loop.declare(self.scene.roster, 0.0)

    def step(self, k: int) -> None:
        """Decision step ``k`` flown; the loop finished after the last."""
        fly_step(self.loop, self.scene, k, self.airframes, self._navigator_error)
        if k == self.steps - 1:
            self.loop.finish(self.steps * self.loop.step_s)

    def record(self) -> RunRecord:
        return _record(self.planner, self.seed, self.nav, self.loop, self.scene, self.steps, self.dt, self.navigated)

    def _navigator_error(self, step: int, substep: int) -> None:
        navigator = self.loop.engine.navigator
        if substep == 0 and navigator is not None:
            stamp = round(step * self.dt * 1e9)
            for i, vehicle_id in enumerate(self.scene.roster):
                estimate = navigator.position_at(vehicle_id, stamp)
                if estimate is not None:
                    self.navigated[step, i] = np.hypot(*(estimate[0] - self.airframes.state.xy[i]))


def _record(planner: str, seed: int, navigation: str, loop: EngineLoop, scene: UrbanScene, steps: int, dt: float,
            navigated: NDArray[np.float64]) -> RunRecord:
    """The run's record from the engine's step records and published tracks, and the scene's truth."""
    roster = scene.roster
    seen = np.zeros((steps, len(roster)), dtype=bool)
    for record in loop.engine.records:
        if record.index < steps:
            seen[record.index] = [record.seen[v] for v in roster]
    errors, nees, decisions = np.full(steps, np.nan), np.full(steps, np.nan), np.full(steps, np.nan)
    estimate_xy = np.full((steps, 2), np.nan)
    for k in range(steps):
        stamp = round(k * dt * 1e9)
        tracks = loop.tracks.get(stamp)
        if tracks:
            track = tracks[-1]
            n = len(track.state)
            estimate_xy[k] = track.state[:2]
            error = estimate_xy[k] - scene.target_xy[k]
            cov = np.asarray(track.covariance, dtype=np.float64).reshape(n, n)[:2, :2]
            errors[k], nees[k] = np.hypot(*error), float(error @ np.linalg.solve(cov, error))
        if stamp in loop.plan_seconds:
            decisions[k] = loop.plan_seconds[stamp]
    planned = np.full((steps, len(roster)), np.nan)
    for k in range(steps):
        for command in loop.commands.get(round(k * dt * 1e9), ()):
            planned[k, roster.index(command.vehicle_id)] = command.turn_rate_rad_s
    simulated = navigation != "perfect" or bool(loop.engine.scenario.gps_denied)  # GPS and INS flown
    nav_error = navigated if navigation == "skf" else scene.nav_error_m if simulated else None
    return RunRecord(planner, seed, seen, errors, decisions, scene.vehicle_xy, scene.target_xy, estimate_xy,
                     scene.violations, nees, navigation, nav_error, scene.gps_fix if simulated else None,
                     scene.vehicle_heading, planned, dict(loop.engine.counters_now()))


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
