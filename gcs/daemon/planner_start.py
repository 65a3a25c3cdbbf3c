"""Which planner the daemon runs: in a process of its own, on a thread, or inline (``gcs run --plan-in``).

The planners themselves are :mod:`gcs.daemon.plan_runners` (thread, inline and the job they run) and
:mod:`gcs.daemon.planner_process` (the process, which builds on the first).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gcs.config import Scenario
from gcs.core.tracker import TrackerConfig
from gcs.core.world import World
from gcs.daemon.planner_process import ProcessPlanner
from gcs.daemon.plan_runners import PLANNER_MODES, PLANNER_NICENESS, InlinePlanner, Planner, ThreadPlanner

__all__ = ["start_planner"]


def start_planner(mode: str, scenario: Scenario, world: World, planner_name: str, seed: int,
                  configs: Callable[[tuple[int, ...]], TrackerConfig], niceness: int = PLANNER_NICENESS) -> Planner:
    """The planner of a mode in :data:`PLANNER_MODES`; ``configs`` maps roster indices to their tracker;
    ``niceness``: the process's, below the daemon's."""
    if mode == "process":
        return ProcessPlanner(scenario, world, planner_name, seed, niceness)
    if mode == "thread":
        return ThreadPlanner(configs, np.random.default_rng(seed))
    if mode == "inline":
        return InlinePlanner(configs, np.random.default_rng(seed))
    raise ValueError(f"planner mode must be one of {', '.join(PLANNER_MODES)}, got {mode!r}")
