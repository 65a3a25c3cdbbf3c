"""Plans made at once, with no deadline, for shells without a planner of their own: replay and the benches.

``gcs replay --plan`` (:mod:`gcs.recordings.replay`) and the benchmarks' closed loops (``gcs-bench``) plan
each job the engine submits (:class:`~gcs.engine.events.SubmitPlan`) before the next input, to
the end of every generation (the planner's ``now`` is None: no deadline), so that their plans are a
function of the inputs and the seed alone; the daemon's planner stops at its deadline instead
(:mod:`gcs.daemon.plan_runners`). A shell that measures how long planning takes passes its own
``clock``: the outcome carries the times it read, the plan does not depend on them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gcs.core.planners.problem import PlanResult
from gcs.core.tracker import TrackerConfig, TrackerState
from gcs.engine.plan_jobs import PlanJob, PlanOutcome, plan_job
from gcs.engine.engine import Engine
from gcs.engine.events import Action, PlanDone

__all__ = ["plan_at_once", "JobPlanner"]

JobPlanner = Callable[[PlanJob, TrackerConfig, np.random.Generator], tuple[TrackerState, np.ndarray, PlanResult | None]]
"""How a job is planned with the tracker of its vehicles (:func:`~gcs.engine.plan_jobs.plan_job`, no deadline)."""


def plan_at_once(engine: Engine, job: PlanJob, rng: np.random.Generator, planner: JobPlanner = plan_job,
                 clock: Callable[[], float] | None = None) -> list[Action]:
    """Plan ``job`` with the engine's tracker for its vehicles, no deadline; the actions of the finished plan.

    ``planner`` plans the job (the engine's :func:`~gcs.engine.plan_jobs.plan_job` unless a shell compares
    another way of planning it); ``clock`` (seconds), when given, stamps the outcome's start and end, so
    that its ``planning_s`` is the time the plan took."""
    started = 0.0 if clock is None else clock()
    state, turn_rates, result = planner(job, engine.subset(job.indices), rng)
    finished = 0.0 if clock is None else clock()
    return engine.feed(PlanDone(PlanOutcome(job, state, turn_rates, result, started, finished, 0)))
