"""The engine's plans: what to plan and when (the hand-over), and what a finished plan does.

:meth:`PlanHandOver.hand_over` gives the (free) planner the newest fused step's planning
(:class:`~gcs.engine.memory.Planning`, kept in :attr:`LoopMemory.waiting
<gcs.engine.memory.LoopMemory.waiting>`), for the vehicles alive when it was fused, at most every
:func:`~gcs.engine.memory.plan_interval_s`; its job is built then, with the warm start of the plan
just applied. :meth:`PlanHandOver.finished` takes a finished plan back: it is kept as the warm start,
its ``PlanCommand`` s are published, and each vehicle's path to steer along is kept (unless the
vehicles were given back on a lost target).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.kinematics import VehicleState
from gcs.core.steering import PlannedPath
from gcs.core.tracker import TrackerConfig
from gcs.engine.events import Action, PublishPlan, SubmitPlan
from gcs.engine.fusion import plan_commands
from gcs.engine.memory import LoopMemory, plan_interval_s
from gcs.engine.options import EngineOptions
from gcs.engine.plan_jobs import PlanJob, PlanOutcome
from gcs.engine.records import PlanRecord
from gcs.engine.tracker_factory import subset_config

__all__ = ["PlanHandOver"]


class PlanHandOver:
    """The plans of one scenario's roster (see the module docstring); ``loop`` and ``counters`` are the engine's."""

    def __init__(self, scenario: Scenario, options: EngineOptions, tracker: TrackerConfig, planner_name: str,
                 loop: LoopMemory, counters: Counter[str]) -> None:
        self.scenario, self.options, self.tracker, self.planner_name = scenario, options, tracker, planner_name
        self.loop, self.counters = loop, counters
        self.roster = [v.id for v in scenario.vehicles]
        self.vehicle_config = {v.id: v for v in scenario.vehicles}
        self._subset_configs: dict[tuple[int, ...], TrackerConfig] = {}

    def subset(self, indices: tuple[int, ...]) -> TrackerConfig:
        """The tracker for a subset of the roster (vehicles lost are planned without), cached."""
        config = self._subset_configs.get(indices)
        if config is None:
            config = self._subset_configs[indices] = subset_config(self.tracker, indices)
        return config

    def hand_over(self, now: float) -> list[Action]:
        """Give the newest fused step's planning to the (free) planner, :func:`plan_interval_s` after the
        last hand-over; its job is built now, with the warm start of the plan just applied."""
        planning = self.loop.waiting
        if planning is None or now < self.loop.next_plan_s:
            return []
        self.loop.waiting = None
        if not self.options.plan_every_step:
            self.loop.next_plan_s = now + plan_interval_s(len(planning.active))
        ready, active, estimate = planning.ready, planning.active, planning.estimate
        return [SubmitPlan(PlanJob(
            index=ready.index, stamp_ns=ready.stamp_ns, active=active,
            indices=tuple(self.roster.index(v) for v in active),
            state=self.loop.memory.state_for(active, estimate),
            vehicles=planning.vehicles.at(ready.stamp_ns), predicted=planning.predicted,
            clock_scale=planning.clock_scale, submitted_s=planning.fused_s, targets=planning.targets))]

    def finished(self, outcome: PlanOutcome) -> tuple[list[Action], PlanRecord | None]:
        """A finished plan: keep it as the warm start, publish the plans, steer the vehicles along them; the
        actions and the plan's record (None for a plan that failed)."""
        job, state, turn_rates, result = outcome.job, outcome.state, outcome.turn_rates, outcome.result
        if outcome.error is not None or state is None or turn_rates is None or result is None:
            self.counters["errors.planning"] += 1
            return [], None
        self.loop.memory.remember(job.active, state, turn_rates)
        self.counters["decisions"] += 1
        actions = self._command(list(job.active), job.vehicles, self.subset(job.indices), result.controls,
                                job.stamp_ns)
        return actions, PlanRecord(job.index, job.stamp_ns, job.active, outcome.waited_s, outcome.planning_s,
                                   result.elapsed_s / job.clock_scale, outcome.finished_ns)

    def _command(self, active: list[str], vehicles: VehicleState, config: TrackerConfig, controls: NDArray[np.float64],
                 stamp_ns: int) -> list[Action]:
        dt = self.scenario.time.step_s
        configs = [self.vehicle_config[v] for v in active]
        commands = plan_commands(vehicles, configs, controls, config.max_turn_rate, dt, stamp_ns,
                                 self.loop.plan_seq + 1, self.planner_name)
        self.loop.plan_seq += len(commands)
        actions: list[Action] = []
        for slot, (command, cfg) in enumerate(zip(commands, configs)):
            actions.append(PublishPlan(command))
            if self.loop.target_lost:
                continue
            start = VehicleState(vehicles.xy[slot:slot + 1], vehicles.heading[slot:slot + 1],
                                 np.array([cfg.speed_mps]), np.array([cfg.altitude_m]))
            self.loop.paths[command.vehicle_id] = PlannedPath.from_plan(start, controls[slot], dt,
                                                                        float(config.max_turn_rate[slot]))
            self.loop.path_stamps_ns[command.vehicle_id] = stamp_ns
        return actions
