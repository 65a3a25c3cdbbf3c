"""Plans made at once, with no deadline, for shells without a planner of their own: replay and the benches.

``gcs replay --plan`` (:mod:`gcs.recordings.replay`) and ``gcs-bench autopilots`` (:mod:`benchmarks.autopilots`)
plan each job the engine submits (:class:`~gcs.engine.events.SubmitPlan`) before the next input, to
the end of every generation (the planner's ``now`` is None: no deadline), so that their plans are a
function of the inputs and the seed alone; the daemon's planner stops at its deadline instead
(:mod:`gcs.daemon.plan_runners`).
"""

from __future__ import annotations

import numpy as np

from gcs.engine.plan_jobs import PlanJob, PlanOutcome, plan_job
from gcs.engine.engine import Engine
from gcs.engine.events import Action, PlanDone

__all__ = ["plan_at_once"]


def plan_at_once(engine: Engine, job: PlanJob, rng: np.random.Generator) -> list[Action]:
    """Plan ``job`` with the engine's tracker for its vehicles, no deadline; the actions of the finished plan."""
    state, turn_rates, result = plan_job(job, engine.subset(job.indices), rng)
    return engine.feed(PlanDone(PlanOutcome(job, state, turn_rates, result, 0.0, 0.0, 0)))
