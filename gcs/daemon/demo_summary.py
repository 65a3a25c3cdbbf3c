"""What ``gcs demo`` shows: a line of progress as it flies, and the summary at the end.

Every count is given with what it counts out of (``seen in 297/300 steps``). With one target
the track's error is the fused position RMSE against the simulator's truth; with many
(``[multitarget]``) it is the GOSPA mean: each decision step's GOSPA of the confirmed
tracks against every target's truth (cut-off :data:`~gcs.engine.records.GOSPA_CUTOFF_M`,
p = 2, alpha = 2), averaged over the scored steps, the figure ``gcs replay --process`` and
``gcs-bench multitarget`` give under the same name. The steering commands' age is judged
against the decision period (:func:`gcs.daemon.status_text.keeps_up`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gcs.engine.records import PlanRecord, StepRecord, step_error_m
from gcs.daemon.status_text import command_age_text

__all__ = ["summarise", "Progress", "print_summary", "error_name"]


def error_name(many_targets: bool) -> str:
    """The name of the track's error figure: ``RMSE`` (one target) or ``GOSPA mean`` (many)."""
    return "GOSPA mean" if many_targets else "RMSE"


def summarise(records: list[StepRecord], plans: list[PlanRecord], vehicles: list[str],
              targets: Sequence[str] = ()) -> dict:
    """The demo's summary of the daemon's decision steps and of its plans (``decision_ms``: the planner's solve);
    with many targets, the steps each of ``targets`` had a track on it."""
    errors = np.array([r.error_m for r in records if r.error_m is not None])
    decisions = np.array([p.solve_s for p in plans]) * 1e3
    nav_std = np.array([s for r in records for s in r.nav_std_m.values()])
    return {
        "steps": len(records),
        "seen_any": sum(any(r.seen.values()) for r in records),
        "seen_per_uav": {v: sum(r.seen.get(v, False) for r in records) for v in vehicles},
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else None,
        "scored_steps": int(errors.size),
        "decision_ms_median": float(np.median(decisions)) if decisions.size else None,
        "decision_ms_p99": float(np.percentile(decisions, 99)) if decisions.size else None,
        "nav_std_m_median": float(np.median(nav_std)) if nav_std.size else None,
        "nav_std_m_max": float(nav_std.max()) if nav_std.size else None,
        "nav_vehicle_steps_without_fix": sum(not fix for r in records for fix in r.gps_fix.values()),
        **_many_targets(records, targets),
    }


def _many_targets(records: list[StepRecord], targets: Sequence[str]) -> dict:
    """With ``[multitarget]``: the GOSPA mean of the scored steps and, per target, the steps a track was on it."""
    scored = [r for r in records if r.gospa_m is not None]
    if not any(r.tracks_xy is not None for r in records):
        return {}
    per_target = {name: 0 for name in targets}
    for record in scored:
        for name in record.tracked:
            per_target[name] = per_target.get(name, 0) + 1
    return {"gospa_m_mean": float(np.mean([r.gospa_m for r in scored])) if scored else None,
            "gospa_steps": len(scored), "tracks_last_step": len(records[-1].tracks_xy or ()) if records else 0,
            "tracked_steps_per_target": dict(sorted(per_target.items()))}


class Progress:
    """One line, rewritten in place on a terminal; a line every 30 steps otherwise."""

    def __init__(self, stream, duration_s: float) -> None:
        self.stream, self.duration_s = stream, duration_s
        self.tty = stream.isatty()
        self.seen = self.steps = 0
        self.total, self.squares, self.scored = 0.0, 0.0, 0
        self.solve_s: float | None = None

    def planned(self, record: PlanRecord) -> None:
        self.solve_s = record.solve_s

    def __call__(self, record: StepRecord) -> None:
        self.steps += 1
        self.seen += any(record.seen.values())
        error = step_error_m(record)
        if error is not None:
            self.total += error
            self.squares += error**2
            self.scored += 1
        many = record.tracks_xy is not None
        if not self.scored:
            figure = None
        else:  # the GOSPA mean with many targets, else the RMSE
            figure = self.total / self.scored if many else math.sqrt(self.squares / self.scored)
        shown = f"{figure:6.1f} m" if figure is not None else "     - "
        decision = f"{self.solve_s * 1e3:5.0f} ms" if self.solve_s is not None else "    - "
        line = (f"step {self.steps:4d}/{self.duration_s:.0f}  seen by any {self.seen:4d}/{self.steps}  "
                f"{error_name(many)} {shown}  decision {decision}  UAVs {len(record.vehicles)}")
        if self.tty:
            self.stream.write("\r" + line)
            self.stream.flush()
        elif self.steps % 30 == 0:
            self.stream.write(line + "\n")

    def end(self) -> None:
        if self.tty:
            self.stream.write("\n")


def print_summary(summary: dict, step_s: float) -> None:
    """The summary's lines (``summary`` as :func:`summarise` gives it, with the demo's settings added)."""
    steps = summary["steps"]
    if summary.get("interrupted"):
        planned = round(summary["duration_s"] / step_s)
        print(f"interrupted after {steps} of {planned} steps: the figures below are of the steps flown")
    many = "gospa_m_mean" in summary
    per_uav = ", ".join(f"{v} {n}/{steps}" for v, n in summary["seen_per_uav"].items())
    print(f"steps {steps}; {'a target' if many else 'target'} seen by at least one UAV in {summary['seen_any']}/{steps}; "
          f"per UAV {per_uav}")
    median, p99 = (_ms(summary[key]) for key in ("decision_ms_median", "decision_ms_p99"))
    if not many:
        rmse = "-" if summary["rmse_m"] is None else \
            f"{summary['rmse_m']:.1f} m over {summary['scored_steps']}/{steps} steps"
        print(f"fused position RMSE {rmse} against the simulator's truth")
    else:
        per_target = ", ".join(f"{t} {n}/{steps}" for t, n in summary["tracked_steps_per_target"].items()) or "none"
        gospa = "-" if summary["gospa_m_mean"] is None else \
            f"{summary['gospa_m_mean']:.1f} m over {summary['gospa_steps']}/{steps} steps"
        print(f"tracks: {error_name(True)} {gospa} against every target's truth; {summary['tracks_last_step']} "
              f"confirmed at the end; steps with a track on each target: {per_target}")
    print(f"decision time (the planner's solve) median {median}, p99 {p99}")
    print(command_age_text(summary.get("command_age_ms_median"), summary.get("command_age_ms_p99"), step_s,
                           summary.get("rate")))
    if summary.get("nav_std_m_median") is not None:
        print(f"navigation {summary['navigation']}: vehicle position 1-sigma median {summary['nav_std_m_median']:.1f} m, "
              f"max {summary['nav_std_m_max']:.1f} m; {summary['nav_vehicle_steps_without_fix']} vehicle-steps "
              "without GPS")
    if summary["rejected"]:
        print("rejected: " + ", ".join(f"{k} {v}" for k, v in sorted(summary["rejected"].items())))


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f} ms"
