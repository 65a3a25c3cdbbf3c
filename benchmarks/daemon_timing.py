"""``gcs-bench daemon``'s timings: a trial's figures, and the latencies from the daemon's step and plan hooks.

:func:`step_latencies_ms` and :func:`track_latencies_ms` turn the send times of each
step's last report and what the daemon's ``on_step`` / ``on_plan`` hooks saw
(:class:`StepTiming`, :class:`PlanTiming`) into latencies; :class:`Trial` holds one
trial's figures (:mod:`benchmarks.daemon` runs them).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Trial", "StepTiming", "PlanTiming", "step_latencies_ms", "track_latencies_ms", "percentiles"]


@dataclass(frozen=True)
class Trial:
    """One trial at one target rate (times in ms; None where there was nothing to measure)."""

    rate_per_s: float
    achieved_per_s: float
    published: int
    accepted: int
    rejected: int
    late: int
    decision_errors: int
    lag_s: float | None
    daemon_cpu: float
    load_cpu: float
    steps: int
    planned_steps: int
    latency_ms_p50: float | None
    latency_ms_p99: float | None
    latency_with_planner_ms_p50: float | None
    latency_with_planner_ms_p99: float | None
    track_latency_ms_p50: float | None
    track_latency_ms_p99: float | None
    visibility_ms_median: float | None
    solve_ms_median: float | None
    solve_ms_p99: float | None
    passed: bool | None
    command_age_ms_median: float | None = None
    """The steering commands' age over the trial (:class:`gcs.engine.memory.CommandAges`: the vehicle time
    at which a command is flown less the stamp of the step its plan came from), newest 1,000."""
    command_age_ms_p99: float | None = None


@dataclass(frozen=True)
class StepTiming:
    """One decision step as the daemon's ``on_step`` saw it: fused and its track published at ``fused_ns``."""

    stamp_ns: int
    fused_ns: int


@dataclass(frozen=True)
class PlanTiming:
    """One plan as the daemon's ``on_plan`` saw it: the planner finished at ``finished_ns``, and
    the loop put its commands at ``put_ns``; ``solve_s`` and ``planning_s`` (visibility regions
    and solve) for the table."""

    stamp_ns: int
    finished_ns: int
    put_ns: int
    planning_s: float
    solve_s: float


def step_latencies_ms(last_sent_ns: dict[int, int], steps: Iterable[StepTiming], plans: Iterable[PlanTiming],
                      planner: bool = False) -> list[float]:
    """Report-to-command latency (ms) of every step of ``last_sent_ns`` (stamp -> send time of its last report).

    A step is served by the first plan, in the order their commands were put, for
    it or a newer step (the planner thread plans the newest fused step only). The
    path from the step's last report to its commands is: sent -> fused (the
    ``TrackEstimate`` put; its planning waits in the loop for the planner) -> the planner's
    share (waiting for a plan of it or of a newer step, then planning) -> the plan
    taken by the loop and its commands put. Latency without the planner is the
    first and last legs, ``(fused - sent) + (put - finished)``; with it
    (``planner``), ``put - sent``.
    """
    fused = {step.stamp_ns: step.fused_ns for step in steps}
    pending = sorted((stamp, sent) for stamp, sent in last_sent_ns.items() if stamp in fused)
    out, first = [], 0
    for plan in plans:
        while first < len(pending) and pending[first][0] <= plan.stamp_ns:
            stamp, sent = pending[first]
            latency_ns = plan.put_ns - sent if planner else (fused[stamp] - sent) + (plan.put_ns - plan.finished_ns)
            out.append(latency_ns / 1e6)
            first += 1
    return out


def track_latencies_ms(last_sent_ns: dict[int, int], steps: Iterable[StepTiming]) -> list[float]:
    """Report-to-track latency (ms): the step's ``TrackEstimate`` put - the send time of its last report."""
    return [(step.fused_ns - last_sent_ns[step.stamp_ns]) / 1e6 for step in steps if step.stamp_ns in last_sent_ns]


def percentiles(values: Sequence[float]) -> tuple[float | None, float | None]:
    """(median, 99th percentile), or (None, None) for no values."""
    if not values:
        return None, None
    return float(np.median(values)), float(np.percentile(values, 99))
