"""Where the daemon runs its planner: in a process of its own, on a thread, or inline (``gcs run --plan-in``).

The plan runners themselves are :mod:`gcs.daemon.plan_runners` (thread, inline and the job they run) and
:mod:`gcs.daemon.plan_process` (the process, which builds on the first).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gcs.config import Scenario
from gcs.core.tracker import TrackerConfig
from gcs.core.world import World
from gcs.daemon.plan_process import ProcessPlanRunner
from gcs.daemon.plan_runners import (PLAN_PROCESS_NICENESS, PLAN_RUNNERS, InlinePlanRunner, PlanRunner,
                                     ThreadPlanRunner)

__all__ = ["start_plan_runner"]


def start_plan_runner(runner: str, scenario: Scenario, world: World, planner_name: str, seed: int,
                      configs: Callable[[tuple[int, ...]], TrackerConfig],
                      niceness: int = PLAN_PROCESS_NICENESS, autopilot_turn_rates: bool = False) -> PlanRunner:
    """The plan runner ``runner`` names (:data:`PLAN_RUNNERS`), running planner ``planner_name``; ``configs`` maps
    roster indices to their tracker; ``niceness``: the process's, below the daemon's; ``autopilot_turn_rates``:
    the engine's option of that name, for the process's own tracker."""
    if runner == "process":
        return ProcessPlanRunner(scenario, world, planner_name, seed, niceness, autopilot_turn_rates)
    if runner == "thread":
        return ThreadPlanRunner(configs, np.random.default_rng(seed))
    if runner == "inline":
        return InlinePlanRunner(configs, np.random.default_rng(seed))
    raise ValueError(f"plan runner must be one of {', '.join(PLAN_RUNNERS)}, got {runner!r}")
