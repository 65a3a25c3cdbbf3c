"""``gcs-bench sharing``: UAVs shared between several targets, closed loop through the engine.

**Scene per seed**: the truths of :func:`benchmarks.multitarget.make_scene` (``targets``
street-following targets on the wang2012_urban city, a side-by-side pair among them),
every draw from ``numpy.random.default_rng(seed)``; the UAVs start where that bench's
fixed orbits start (:data:`~benchmarks.multitarget.ORBITS`), at the scenario's altitudes,
speeds and turn limits.

**Loop** (:mod:`benchmarks.closed_loop`), one decision step a second: each UAV scans from where it is
(line of sight past the buildings, range, ``pd`` and Poisson clutter:
:func:`sim_vehicles.truth.detections.scan`, its draws from ``default_rng([seed, 1])``) and reports
the scan to the engine (:mod:`benchmarks.many_targets_loop`), which tracks every target with its JPDA
(``[multitarget]``), keeps the lost targets (confirmed tracks it deleted, searched for :data:`FORGET_S`)
and submits each fused step's plan job: the confirmed tracks and lost targets over the horizon, each
weighted by the time it has gone without a detection. The **modes**:

* ``sum``: the job planned by the sight objective summed over the targets with those weights
  (:meth:`~gcs.core.planners.sequential.SightPlanner.solve_shared`, :func:`plan_summed`);
* ``assign``: the engine's own planning, each UAV assigned one target, then each target planned for
  with its own UAVs (:meth:`~gcs.core.planners.sequential.SightPlanner.solve_assigned`);
* ``orbit``: no planner, each UAV keeps its fixed orbit (the baseline of ``gcs-bench multitarget``).

The UAVs fly the plans' turn rates (the ideal airframe, wang2012 eq. 1); a UAV not steered (nothing
to plan for yet, or given back by the engine) loiters on its home orbit. The planner's draws come
from ``default_rng([seed, 2])``.

**Scores** per run, over the steps after the warm-up (all but the last, in a run no longer than it): for each target, the steps in
which some UAV has it in its field (in range and in sight, before ``pd``); their mean
and their minimum over the targets (a starved target shows in the minimum); for each
UAV, the steps in which it has some target in its field; the mean GOSPA of the
confirmed tracks the engine published (:data:`~benchmarks.multitarget.CUTOFF_M`, p = 2, alpha = 2); and
the median planning time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from benchmarks import multitarget as mt
from benchmarks.closed_loop import EngineLoop, IdealAirframes, Loiter, fly
from benchmarks.many_targets_loop import SharingScene, confirmed, many_target_scenario
from gcs.config import Scenario
from gcs.core.kinematics import VehicleState
from gcs.core.metrics import gospa
from gcs.core.multitarget.planning import problems_for
from gcs.core.planners.problem import PlanResult
from gcs.core.tracker import TrackerConfig, TrackerState
from gcs.core.world import World
from gcs.engine.plan_jobs import PlanJob, plan_job

__all__ = ["MODES", "STARVATION_S", "SharingConfig", "SharingRun", "fly_run", "plan_summed"]

MODES = ("sum", "assign", "orbit")
STARVATION_S = 20.0
"""``tau`` of :func:`gcs.core.planners.shared.target_weights`: an unseen track's claim doubles in 20 s."""
FORGET_S = 90.0
"""A lost target (:class:`gcs.core.multitarget.lost.LostTargets`) is searched for this long."""


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


def _start(scene: mt.Scene, speeds: NDArray[np.float64]) -> VehicleState:
    """The UAVs where the fixed orbits put them at step 0, heading along the orbit."""
    xyz, ahead = scene.vehicle_xyz[0], scene.vehicle_xyz[1]
    heading = np.arctan2(ahead[:, 1] - xyz[:, 1], ahead[:, 0] - xyz[:, 0])
    return VehicleState(xyz[:, :2].copy(), heading, speeds, xyz[:, 2].copy())


def plan_summed(job: PlanJob, config: TrackerConfig, rng: np.random.Generator
                ) -> tuple[TrackerState, NDArray[np.float64], PlanResult]:
    """The ``sum`` mode's plan of a many-target job: the sight objective summed over its targets with their
    weights (:meth:`~gcs.core.planners.sequential.SightPlanner.solve_shared`), kept out of restricted airspace."""
    targets = job.targets
    problems = problems_for(config, job.vehicles, job.state.turn_rate, targets.means, targets.covs)
    result = config.planner.solve_shared(problems, targets.weights, rng, job.state.plan)
    safe = config.guard.safe(job.vehicles, result.controls, config.step_s, config.max_turn_rate)
    if safe is not result.controls:
        result = replace(result, controls=safe, message=f"{result.message}; airspace fallback")
    turn_rate = result.controls[:, 0].copy()
    return TrackerState(job.state.estimate, result.controls, turn_rate), turn_rate, result


def fly_run(mode: str, world: World, team: Scenario, seed: int, sharing: SharingConfig) -> SharingRun:
    """One run of ``mode`` on seed ``seed`` (module docstring) by ``team``'s UAVs (its first ones on the fixed
    orbits, more on a ring: :func:`benchmarks.multitarget.orbits`)."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; expected one of {', '.join(MODES)}")
    bench = sharing.scene
    scenario = many_target_scenario(team, "jpda", bench.pd, bench.clutter, len(team.vehicles), sharing.starvation_s,
                                    FORGET_S)
    roster = [v.id for v in scenario.vehicles]
    speeds = np.array([v.speed_mps for v in scenario.vehicles])
    scene = mt.make_scene(world, [v.altitude_m for v in scenario.vehicles], bench, np.random.default_rng(seed))
    planned = mode != "orbit"
    loop = EngineLoop(scenario, world, np.random.default_rng([seed, 2]),
                      planner=plan_summed if mode == "sum" else plan_job, plans=planned)
    config = loop.engine.tracker
    sim = SharingScene(roster, world, scene, config.sensors[0], config.max_range_m, bench.pd, bench.clutter,
                       np.random.default_rng([seed, 1]), config.step_s, prescribed=not planned)
    homes = [Loiter((cx, cy), radius) for cx, cy, radius in mt.orbits(len(roster))]
    airframes = IdealAirframes(roster, _start(scene, speeds), config.max_turn_rate, config.step_s,
                               scenario.simulation.airframe.loiter_radius_m, homes) if planned else None
    loop.declare(roster, 0.0)
    steps = len(scene.truth_xy)
    fly(loop, sim, steps, airframes)
    scored = slice(min(bench.warm_up, steps - 1), steps)
    field = sim.field[scored]
    gospas = [gospa(confirmed(loop, k)[1], scene.truth_xy[k], mt.CUTOFF_M, mt.ORDER_P).distance
              for k in range(scored.start, steps)]
    scan_seconds = tuple(loop.tick_seconds[k] for k in range(steps))
    plans = {round(stamp / 1e9): seconds for stamp, seconds in loop.plan_seconds.items()}
    decision_seconds = tuple(scan_seconds[k] + plans.get(k, 0.0) for k in range(steps))
    return SharingRun(field.any(axis=1).sum(axis=0), field.any(axis=2).sum(axis=0),
                      float(np.mean(gospas)) if gospas else math.nan, tuple(plans.values()), decision_seconds,
                      scan_seconds, sim.detections)
