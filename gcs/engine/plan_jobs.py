"""The plan jobs: what the engine hands a planner (:class:`PlanJob`), what comes back (:class:`PlanOutcome`),
and how a job is planned (:func:`plan_job`).

The engine builds a job from the newest fused step when the planner is free
(:class:`~gcs.engine.events.SubmitPlan`) and takes back its outcome
(:class:`~gcs.engine.events.PlanDone`); it never plans itself. Who plans, and with
which clock for the deadline, is the shell's: the daemon's plan runners
(:mod:`gcs.daemon.plan_runners`: a process, a thread or inline), or
:func:`gcs.engine.plan_at_once.plan_at_once` with no deadline for replay and the benches.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.kinematics import VehicleState
from gcs.core.multitarget.planning import TargetsToPlan, plan_targets
from gcs.core.planners.problem import PlanResult
from gcs.core.tracker import TrackerConfig, TrackerState, plan

__all__ = ["PlanJob", "PlanOutcome", "plan_job"]


@dataclass(frozen=True)
class PlanJob:
    """Everything one plan needs, built on the loop when it is handed over: the step's estimate,
    prediction and vehicles as they were when it was fused, the warm start of the plan applied last.

    Attributes
    ----------
    index, stamp_ns : int
        The decision step the plan is for.
    active : tuple of str
        The vehicles planned (the rows of ``vehicles`` and of the plan).
    indices : tuple of int
        Their places in the roster (which tracker to plan with: ``subset_config``).
    state : TrackerState
        The fused estimate, the warm start and the turn rates being flown.
    vehicles : VehicleState
        The vehicles' states at ``stamp_ns``.
    predicted : HorizonPrediction
        The k+1..k+n prediction already published with the track.
    clock_scale : float
        The planner's clock is ``time.monotonic`` times this (data time per wall
        second over the share of the step the planner may use; see
        :meth:`LoopMemory.clock_scale <gcs.engine.memory.LoopMemory.clock_scale>`): its deadline is in data time.
    submitted_s : float
        ``time.monotonic`` when its step was fused (the engine keeps the newest step's
        planning until the planner is free, then builds the job).
    targets : TargetsToPlan or None
        With ``[multitarget]``: the tracks the vehicles are shared between
        (:func:`gcs.core.multitarget.planning.plan_targets`); ``state.estimate`` and
        ``predicted`` are then None.
    """

    index: int
    stamp_ns: int
    active: tuple[str, ...]
    indices: tuple[int, ...]
    state: TrackerState
    vehicles: VehicleState
    predicted: HorizonPrediction | None
    clock_scale: float
    submitted_s: float
    targets: TargetsToPlan | None = None


@dataclass(frozen=True)
class PlanOutcome:
    """A finished job: the new tracker state and first turn rates, or the error that stopped it.

    ``started_s - job.submitted_s`` is the time the job waited (the planner was
    busy with the previous plan); ``finished_s - started_s`` is the planning
    time (visibility regions and solve); both ``time.monotonic``.
    ``finished_ns`` is ``time.time_ns`` at the end (to compare with other processes).
    """

    job: PlanJob
    state: TrackerState | None
    turn_rates: NDArray[np.float64] | None
    result: PlanResult | None
    started_s: float
    finished_s: float
    finished_ns: int
    error: str | None = None

    @property
    def waited_s(self) -> float:
        return self.started_s - self.job.submitted_s

    @property
    def planning_s(self) -> float:
        return self.finished_s - self.started_s

    @property
    def solve_s(self) -> float | None:
        """The planner's own solve time in wall seconds (planning less the visibility regions)."""
        return None if self.result is None else self.result.elapsed_s / self.job.clock_scale


def plan_job(job: PlanJob, config: TrackerConfig, rng: np.random.Generator,
             now: Callable[[], float] | None = None) -> tuple[TrackerState, NDArray[np.float64], PlanResult]:
    """The job's plan: the new state, first turn rates and the planner's result (``now`` None: no deadline).
    One target: :func:`gcs.core.tracker.plan`; many: :func:`gcs.core.multitarget.planning.plan_targets`.
    ValueError for a job with neither an estimate nor targets: there is nothing to plan for."""
    if job.targets is not None:
        return plan_targets(config, job.state, job.vehicles, job.targets, rng, now)
    state, turn_rates, diagnostics = plan(config, job.state, job.vehicles, rng, now=now, predicted=job.predicted)
    if diagnostics.plan is None:
        raise ValueError(f"plan job {job.index} has neither an estimate nor targets: nothing to plan")
    return state, turn_rates, diagnostics.plan
