"""``gcs-bench urban``'s timing table: the default planner and the paper's GA, alternated step by step.

For each team size the two planners (:data:`SCALING_PLANNERS`) fly their own closed loop
(:class:`benchmarks.urban.ClosedLoopRun`, the same seed, every step planned, the GA to its full
budget with no early stop) in this process, stepped alternately: step ``k`` of one, then
step ``k`` of the other, the order swapped every step, so a change in the machine's load
lands on both. Each plan job is timed (``time.perf_counter``, in the loop's shell); the table
gives each planner's median, interquartile range and 99th percentile over the steps, and the
GA's time over the default's step by step (the steps both planned): median and
interquartile range.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from benchmarks.urban import ClosedLoopRun, with_vehicles
from gcs.config import Scenario
from gcs.core.world import World

__all__ = ["SCALING_PLANNERS", "scaling_row", "scaling_table", "scaling_lines", "iqr_text"]

SCALING_PLANNERS = ("sight", "ga_k5")


def _spread(values: np.ndarray) -> dict[str, float]:
    if not values.size:
        return {"median": float("nan"), "p25": float("nan"), "p75": float("nan"), "p99": float("nan")}
    p25, median, p75, p99 = np.percentile(values, [25.0, 50.0, 75.0, 99.0])
    return {"median": float(median), "p25": float(p25), "p75": float(p75), "p99": float(p99)}


def scaling_row(scenario: Scenario, world: World, count: int, seed: int, duration_s: float,
                motion: str | None) -> dict:
    """One team size: both planners alternated (module docstring)."""
    bigger = with_vehicles(scenario, count)
    runs = [ClosedLoopRun(bigger, world, name, seed, duration_s=duration_s, motion=motion, stall=None)
            for name in SCALING_PLANNERS]
    for k in range(runs[0].steps):
        for i in range(len(runs)):
            runs[(i + k) % len(runs)].step(k)
    row: dict = {"uavs": count}
    decisions = []
    for name, run in zip(SCALING_PLANNERS, runs):
        record = run.record()
        ms = 1e3 * record.decision_s
        decisions.append(ms)
        timing = _spread(ms[np.isfinite(ms)])
        row[name] = {"decision_ms_median": timing["median"], "decision_ms_p25": timing["p25"],
                     "decision_ms_p75": timing["p75"], "decision_ms_p99": timing["p99"],
                     "seen_any": record.seen_any, "steps": int(record.seen.shape[0])}
    both = np.isfinite(decisions[0]) & np.isfinite(decisions[1])
    ratio = _spread(decisions[1][both] / decisions[0][both])
    row.update(ga_over_sight=ratio["median"], ga_over_sight_p25=ratio["p25"], ga_over_sight_p75=ratio["p75"])
    return row


def scaling_table(scenario: Scenario, world: World, counts: Sequence[int], seed: int, duration_s: float,
                  motion: str | None, say: Callable[[str], None]) -> list[dict]:
    """A row per team size in ``counts``."""
    table = []
    for count in counts:
        row = scaling_row(scenario, world, count, seed, duration_s, motion)
        table.append(row)
        say(f"timing with {count} UAVs: sight median {row['sight']['decision_ms_median']:.1f} ms, "
            f"GA {row['ga_k5']['decision_ms_median']:.1f} ms")
    return table


def iqr_text(row: dict, key: str) -> str:
    """``row``'s ``<key>_p25-<key>_p75``."""
    return f"{row[f'{key}_p25']:.1f}-{row[f'{key}_p75']:.1f}"


def scaling_lines(table: Sequence[dict]) -> list[str]:
    """The timing table as text."""
    if not table:
        return []
    lines = ["", "decision time by team size (ms, every planning step; no early stop; the planners alternated):",
             f"{'UAVs':>5}{'sight median':>14}{'IQR':>13}{'p99':>8}{'GA median':>11}{'IQR':>15}{'p99':>8}"
             f"{'GA / sight':>12}{'IQR':>11}"]
    for row in table:
        s, g = row["sight"], row["ga_k5"]
        lines.append(f"{row['uavs']:>5}{s['decision_ms_median']:>14.1f}{iqr_text(s, 'decision_ms'):>13}"
                     f"{s['decision_ms_p99']:>8.1f}{g['decision_ms_median']:>11.1f}{iqr_text(g, 'decision_ms'):>15}"
                     f"{g['decision_ms_p99']:>8.1f}{row['ga_over_sight']:>12.1f}{iqr_text(row, 'ga_over_sight'):>11}")
    return lines
