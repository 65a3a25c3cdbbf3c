"""What the engine did, step by step and plan by plan: records for the demo's summary, the benchmarks and tests.

A :class:`StepRecord` is made when a decision step is fused and scored against the
simulator's truth at its stamp (the simulator publishes ``TargetTruth`` beside the
reports; real vehicles have none, and then nothing is scored). :class:`StepScorer`
keeps the records in order and lets each wait a little for its truth, which may
arrive after the step was fused. A :class:`PlanRecord` is made when a plan's
commands are put. The daemon runs for days: the newest :data:`MAX_RECORDS` of each
are kept.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np

from gcs.core.metrics import gospa

__all__ = ["StepRecord", "PlanRecord", "StepScorer", "keep_newest", "MAX_RECORDS", "TRUTH_WAIT_S", "MAX_TRUTHS",
           "GOSPA_CUTOFF_M", "step_error_m"]

MAX_RECORDS = 100_000
"""Step (and plan) records kept in memory (about a day of 1 s steps)."""
TRUTH_WAIT_S = 0.5
"""Wall time a step record waits for the simulator's truth at its stamp before it is emitted unscored."""
MAX_TRUTHS = 4096
"""Truth samples kept (the oldest are dropped)."""
GOSPA_CUTOFF_M = 100.0
"""GOSPA's cut-off ``c`` for the many-target steps, as ``gcs-bench multitarget``'s."""


@dataclass(frozen=True)
class StepRecord:
    """What fusing one decision step did, for the demo's summary and for tests.

    ``vehicles`` are those alive (planned for) when the step was fused, at
    ``fused_ns`` (``time.time_ns``); ``error_m`` is against the simulator's truth,
    when there is one. ``nav_std_m`` and ``gps_fix``: each navigated vehicle's horizontal
    1-sigma and whether its last nav report had a GPS fix, when the step was fused
    (empty with ``--navigation reported``).
    """

    index: int
    stamp_ns: int
    seen: dict[str, bool]
    estimate_xy: tuple[float, float] | None
    error_m: float | None
    vehicles: tuple[str, ...]
    fused_ns: int
    nav_std_m: dict[str, float] = field(default_factory=dict)
    gps_fix: dict[str, bool] = field(default_factory=dict)
    tracks_xy: tuple[tuple[float, float], ...] | None = None
    """With ``[multitarget]``: the step's confirmed tracks' positions (None: one target, ``estimate_xy``)."""
    gospa_m: float | None = None
    """GOSPA of ``tracks_xy`` against every target's truth (:data:`GOSPA_CUTOFF_M`, p = 2, alpha = 2)."""
    tracked: tuple[str, ...] = ()
    """The targets whose truth GOSPA's assignment paired with a track (closer than the cut-off)."""


@dataclass(frozen=True)
class PlanRecord:
    """One plan the daemon applied (its commands were just put), in wall seconds.

    ``waited_s``: from the step's fusion to the planner starting on it (the planner
    was busy with the previous plan, and a job is handed over at most every
    ``gcs.engine.memory.plan_interval_s``); ``planning_s``: visibility regions and
    solve; ``solve_s``: the planner's solve alone; ``finished_ns``: ``time.time_ns``
    when the planner finished (the commands were put after it, when the loop took the plan).
    """

    index: int
    stamp_ns: int
    vehicles: tuple[str, ...]
    waited_s: float
    planning_s: float
    solve_s: float
    finished_ns: int


def step_error_m(record: StepRecord) -> float | None:
    """The step's error against the truth: the track's position error, or with many targets the step's GOSPA."""
    return record.error_m if record.tracks_xy is None else record.gospa_m


Kept = TypeVar("Kept")
Found = TypeVar("Found")


def keep_newest(records: list[Kept], limit: int = MAX_RECORDS) -> None:
    """Drop the older half of ``records`` once it holds more than ``limit``."""
    if len(records) > limit:
        del records[: limit // 2]


class StepScorer:
    """Step records, emitted in order, each scored against the truth at its stamp.

    A record waits for its truth until truth of a later stamp has come in, or
    :data:`TRUTH_WAIT_S` of ``clock`` has passed (then it is emitted unscored).
    Without a truth source nothing waits. Emitted records go to ``records`` and to
    ``on_step``.
    """

    def __init__(self, step_ns: int, clock: Callable[[], float],
                 on_step: Callable[[StepRecord], None] | None = None) -> None:
        self.step_ns, self.clock, self.on_step = step_ns, clock, on_step
        self.records: list[StepRecord] = []
        self.truth: dict[int, tuple[float, float]] = {}
        self.truths: dict[int, dict[str, tuple[float, float]]] = {}
        """Every target's truth by stamp (many targets)."""
        self._unscored: deque[tuple[StepRecord, float]] = deque()

    def add_truth(self, stamp_ns: int, position_xy: tuple[float, float], target_id: str | None = None) -> None:
        """The simulator's target position at a stamp: the one target's, or with ``target_id`` one of many."""
        if target_id is None:
            self.truth[stamp_ns] = position_xy
            if len(self.truth) > MAX_TRUTHS:
                del self.truth[min(self.truth)]
            return
        self.truths.setdefault(stamp_ns, {})[target_id] = position_xy
        if len(self.truths) > MAX_TRUTHS:
            del self.truths[min(self.truths)]

    def add(self, record: StepRecord) -> None:
        """A fused step's record, to be scored and emitted in order."""
        self._unscored.append((record, self.clock() + TRUTH_WAIT_S))
        self.score(flush=False)

    def score(self, flush: bool) -> None:
        """Emit the records whose truth is in or no longer expected (all of them with ``flush``)."""
        latest = max(self.truth, default=None)
        latest_many = max(self.truths, default=None)
        while self._unscored:
            record, deadline = self._unscored[0]
            many = record.tracks_xy is not None
            truth = None if record.estimate_xy is None else self.truth_near(record.stamp_ns)
            truths = self._near(self.truths, record.stamp_ns) if many else None
            newest = latest_many if many else latest
            # One target: until its truth is in. Many: until a later step's truth is, so that every target's
            # truth at this stamp is in (the simulator publishes them in stamp order).
            waiting = (many or (record.estimate_xy is not None and truth is None)) and (
                newest is not None and newest < record.stamp_ns + self.step_ns and self.clock() < deadline)
            if waiting and not flush:
                return
            self._unscored.popleft()
            if truth is not None and record.estimate_xy is not None:
                error = math.hypot(record.estimate_xy[0] - truth[0], record.estimate_xy[1] - truth[1])
                record = replace(record, error_m=error)
            if truths:
                record = _with_gospa(record, truths)
            self.records.append(record)
            keep_newest(self.records)
            if self.on_step is not None:
                self.on_step(record)

    def truth_near(self, stamp_ns: int) -> tuple[float, float] | None:
        """The truth at a stamp (within a tenth of a step), if it was published."""
        return self._near(self.truth, stamp_ns)

    def _near(self, by_stamp: dict[int, Found], stamp_ns: int) -> Found | None:
        """``by_stamp``'s entry at a stamp, or within a tenth of a step of it; None without one."""
        found = by_stamp.get(stamp_ns)
        if found is None and by_stamp:
            nearest = min(by_stamp, key=lambda s: abs(s - stamp_ns))
            if abs(nearest - stamp_ns) <= self.step_ns // 10:
                found = by_stamp[nearest]
        return found


def _with_gospa(record: StepRecord, truths: dict[str, tuple[float, float]]) -> StepRecord:
    """The record scored against every target's truth: GOSPA and the targets it paired with a track."""
    names = sorted(truths)
    result = gospa(np.array(record.tracks_xy, dtype=np.float64).reshape(-1, 2),
                   np.array([truths[n] for n in names], dtype=np.float64), GOSPA_CUTOFF_M)
    return replace(record, gospa_m=result.distance,
                   tracked=tuple(n for n, row in zip(names, result.assignment.tolist()) if row >= 0))
