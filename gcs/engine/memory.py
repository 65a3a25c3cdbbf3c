"""The engine's memory between steps, when plans are handed over, and the measured command age.

:class:`LoopMemory` is what one decision step leaves for the next (estimate, warm start,
sequence numbers, the paths the vehicles are steered along, the hand-back on a lost
target); :class:`Planning` is what planning a fused step needs until the planner is free;
:func:`plan_interval_s` spaces the hand-overs; :class:`CommandAges` measures how old the
decision behind each steering command is when it is flown.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.filters.uif import GaussianEstimate
from gcs.core.multitarget.planning import TargetsToPlan
from gcs.core.steering import PlannedPath
from gcs.engine.fusion import PlanMemory
from gcs.engine.registry import VehicleSnapshot
from gcs.engine.steps import ReadyStep

__all__ = ["STEER_RATE_HZ", "MIN_PLAN_INTERVAL_S", "PLAN_INTERVAL_PER_VEHICLE_S", "COMMAND_AGES_KEPT",
           "plan_interval_s", "Planning", "LoopMemory", "CommandAges"]

STEER_RATE_HZ = 4.0
"""How often, per second of vehicle time, the steering along the planned paths is recomputed (the carrot
rate). Against vehicles simulated R times faster than real time it runs R times as often in wall time."""
MIN_PLAN_INTERVAL_S = 0.05
"""Loop time between two plans handed to the planner, at least (more for a large team: :func:`plan_interval_s`).

The vehicles are steered toward the newest plan :data:`STEER_RATE_HZ` times a
second, so plans made much faster than that are never flown. Live (1 s decision
steps) and in the demo (10x) the planner takes longer than this anyway; against
data arriving hundreds of times faster than real time (``gcs-bench daemon``) a
cheap planner (orbit, pursuit) would otherwise cost the loop more in job hand-over
and command publication than the fusion it is there for."""
PLAN_INTERVAL_PER_VEHICLE_S = 0.0025
"""Loop time between two plans for each vehicle planned, at least (see :func:`plan_interval_s`)."""
NS_PER_S = 1_000_000_000
COMMAND_AGES_KEPT = 1000
"""Command ages kept for the median and p99 (:class:`CommandAges`): the newest this many."""


def plan_interval_s(vehicles: int) -> float:
    """The loop time from one plan's hand-over to the next for a team of ``vehicles``:
    :data:`MIN_PLAN_INTERVAL_S`, or :data:`PLAN_INTERVAL_PER_VEHICLE_S` a vehicle if more, and
    never more than a steering period (``1 / STEER_RATE_HZ``).

    Applying a plan costs the loop about 30 us a vehicle (the job, the outcome, a
    ``PlanCommand`` built, encoded and put for each vehicle: 3 ms at 100 vehicles), and
    reports that arrive meanwhile wait. Against data faster than real time a fast
    planner would otherwise be handed a job every 50 ms whatever the team. Measured at
    100 vehicles and 5,000 reports/s (50 steps a second), plans every 50 ms doubled the
    report-to-track p99 against plans every 2 s (docs/benchmarks.md). With 2.5 ms a
    vehicle, plan application stays near 1% of the loop's time; teams of up to 20
    keep 50 ms, 100 vehicles are planned 4 times a second, as often as they are
    steered. Live, with 1 s decision steps, plans are a step apart anyway.
    """
    return min(max(MIN_PLAN_INTERVAL_S, vehicles * PLAN_INTERVAL_PER_VEHICLE_S), 1.0 / STEER_RATE_HZ)


@dataclass(frozen=True)
class Planning:
    """What planning a fused step needs, captured when it was fused: the step, the vehicles alive
    then and what was known of them (their states at its stamp come from that), its estimate,
    the k+1..k+n prediction, the planner's clock scale and when (``monotonic_s`` of its tick); the
    job is built from it when it is handed over."""

    ready: ReadyStep
    active: tuple[str, ...]
    vehicles: VehicleSnapshot
    estimate: GaussianEstimate | None
    predicted: HorizonPrediction | None
    clock_scale: float
    fused_s: float
    targets: TargetsToPlan | None = None
    """With ``[multitarget]`` (``estimate`` and ``predicted`` None): the tracks to share the vehicles between."""


@dataclass
class LoopMemory:
    """The engine's mutable memory between steps (estimate, plan, commands)."""

    estimate: GaussianEstimate | None = None
    memory: PlanMemory = field(default_factory=PlanMemory)
    track_seq: int = 0
    plan_seq: int = 0
    last_track_stamp_ns: int | None = None
    last_seen_ns: int | None = None
    """Stamp of the newest decision step in which a vehicle saw the target."""
    target_lost: bool = False
    """No vehicle has seen the target for ``handback_after_lost_s``: the vehicles are given back."""
    step_times: list[tuple[float, int]] = field(default_factory=list)
    paths: dict[str, PlannedPath] = field(default_factory=dict)
    """Each vehicle's newest planned path, which it is steered along."""
    path_stamps_ns: dict[str, int] = field(default_factory=dict)
    """The stamp of the decision step each vehicle's path was planned from (for the command age)."""
    data_rate: float = 1.0
    waiting: Planning | None = None
    """The newest fused step's planning, until the planner is free to take it."""
    next_plan_s: float = -math.inf

    def clock_scale(self, now_s: float, stamp_ns: int, plan_fraction: float) -> float:
        """How much faster than the loop clock the planner's clock runs (data time, over ``plan_fraction``),
        with the step of ``stamp_ns`` released at ``now_s``.

        The planner's deadline is a fraction of a decision step of *data* time. Live,
        stamps advance as fast as the wall clock; against vehicles simulated R times
        faster than real time the GA gets 1/R of the wall time, so that its command
        still arrives within the step it was planned for. The rate is measured over
        the last few released steps and never below 1 (kept as ``data_rate``). The deadline
        is further shrunk to ``plan_fraction`` of itself, leaving the rest of the step for
        fusion and I/O.
        """
        history = self.step_times
        history.append((now_s, stamp_ns))
        del history[:-6]
        rate = 1.0
        (wall_0, stamp_0), (wall_1, stamp_1) = history[0], history[-1]
        if wall_1 - wall_0 > 1e-3:
            rate = max(1.0, (stamp_1 - stamp_0) / NS_PER_S / (wall_1 - wall_0))
        self.data_rate = rate
        return rate / plan_fraction


class CommandAges:
    """How old the decision behind each steering command is when the vehicle flies it, ms.

    The age of a command is the vehicle time at which it goes out (the newest stamp the
    engine has accepted from the vehicles: their clock, simulation time against simulated
    vehicles) less the stamp of the decision step whose plan it steers along. It is the
    lag of the whole loop as the vehicles live it: the step's wait for its reports, the
    fusion, the wait for the planner, the planning and the steering period. The newest
    :data:`COMMAND_AGES_KEPT` are kept.
    """

    def __init__(self, kept: int = COMMAND_AGES_KEPT) -> None:
        self.ages_ms: deque[float] = deque(maxlen=kept)

    def add(self, flown_ns: int, step_stamp_ns: int) -> None:
        """One command flown at vehicle time ``flown_ns``, steering along the plan of step ``step_stamp_ns``."""
        self.ages_ms.append((flown_ns - step_stamp_ns) / 1e6)

    def median_ms(self) -> float | None:
        """The median age, ms (None before the first command)."""
        return float(np.median(self.ages_ms)) if self.ages_ms else None

    def p99_ms(self) -> float | None:
        """The 99th percentile age (linear interpolation, numpy's default), ms (None before the first command)."""
        return float(np.percentile(self.ages_ms, 99)) if self.ages_ms else None
