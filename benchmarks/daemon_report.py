"""``gcs-bench daemon``'s report: the table of what was measured, the goals, and the JSON.

The measurement is :mod:`benchmarks.daemon`; this module formats it (:func:`format_report`)
and writes it (:func:`write_json`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

__all__ = ["fmt", "format_report", "worst_latency", "write_json"]


def fmt(value: float | None, digits: int = 2) -> str:
    """A figure with ``digits`` decimals, ``-`` for None."""
    return "-" if value is None else f"{value:.{digits}f}"


def _age(row: dict, name: str) -> str:
    """``median/p99`` of a row's ``<name>_median`` and ``<name>_p99`` (a report of before they were measured: -)."""
    return "/".join(fmt(row.get(f"{name}_{q}"), 0) for q in ("median", "p99"))


def format_report(report: dict) -> str:
    """The table, the goals, and what was measured how, on what."""
    lines = [
        f"daemon benchmark: {report['command'] or 'gcs-bench daemon'}",
        f"machine: {report['machine']}; load average {report['load_average']['start']} at start, "
        f"{report['load_average']['end']} at the end (1/5/15 min)",
        f"scenario {report['scenario']}; daemon --navigation {report.get('navigation', 'reported')}"
        f"{' (SKF: a NavReport per vehicle per round too)' if report.get('nav_per_round') else ''}; "
        f"load in a separate process (nice +{report.get('load_niceness', 0)}) over Zenoh TCP on 127.0.0.1; "
        f"{report['seconds_per_trial']:g} s per trial; no loss = every report accepted and the daemon within "
        f"{report['grace_s']:g} s of the last one; latency = last report of a step sent -> its commands put, "
        f"less the planner thread's share ({report['latency_planner']} planner; at 5,000 reports/s, else at the "
        f"max); solve time of {report['solve_planner']} with reports in real time",
        "",
        "latency p50/p99 excludes the planner thread's share (the wait for its previous plan, the visibility "
        "regions and the search); 'with planner' keeps it in; 'track' is report -> TrackEstimate put; 'command "
        "age' is the vehicle time at which a steering command is flown less the stamp of the step its plan came "
        "from (data time: hundreds of times faster than real time in the rate search)",
        f"{'vehicles':>8}{'max reports/s':>15}{'latency p50':>13}{'p99 ms':>8}{'at reports/s':>14}"
        f"{'with planner':>14}{'track p50/p99':>15}{'visibility ms':>15}{'solve ms median':>17}{'p99':>8}"
        f"{'command age p50/p99 ms':>24}",
    ]
    for count, row in report["vehicles"].items():
        with_planner = "/".join(fmt(row[f"latency_with_planner_ms_{q}"], 1) for q in ("p50", "p99"))
        track = "/".join(fmt(row[f"track_latency_ms_{q}"], 1) for q in ("p50", "p99"))
        lines.append(f"{count:>8}{row['max_reports_per_s_no_loss']:>15,.0f}{fmt(row['latency_ms_p50']):>13}"
                     f"{fmt(row['latency_ms_p99']):>8}{fmt(row['latency_at_reports_per_s'], 0):>14}"
                     f"{with_planner:>14}{track:>15}{fmt(row['visibility_ms_median'], 1):>15}"
                     f"{fmt(row['solve_ms_median'], 1):>17}{fmt(row['solve_ms_p99'], 1):>8}"
                     f"{_age(row, 'command_age_ms'):>24}")
    realtime = {count: row["realtime_trial"] for count, row in report["vehicles"].items() if row["realtime_trial"]}
    if realtime:
        lines += ["", f"in real time (one round per decision step), {report['solve_planner']}: latency less the "
                      "planner thread's share, with it, and report -> track",
                  f"{'vehicles':>8}{'latency p50':>13}{'p99 ms':>8}{'with planner':>14}{'track p50/p99':>15}"
                  f"{'visibility ms':>15}{'command age p50/p99 ms':>24}"]
    for count, trial in realtime.items():
        with_planner = "/".join(fmt(trial[f"latency_with_planner_ms_{q}"], 1) for q in ("p50", "p99"))
        track = "/".join(fmt(trial[f"track_latency_ms_{q}"], 1) for q in ("p50", "p99"))
        lines.append(f"{count:>8}{fmt(trial['latency_ms_p50']):>13}{fmt(trial['latency_ms_p99']):>8}"
                     f"{with_planner:>14}{track:>15}{fmt(trial['visibility_ms_median'], 1):>15}"
                     f"{_age(trial, 'command_age_ms'):>24}")
    goals = report["goals"]
    lines += [
        "",
        f"goal >= {goals['reports_per_s']:,} reports/s with no loss at every count: "
        f"{'met' if goals['rate_met'] else 'NOT met'} (lowest max {report['max_reports_per_s_no_loss']:,.0f}/s)",
        f"goal p99 <= {goals['latency_ms_p99']:g} ms at {goals['reports_per_s']:,} reports/s: "
        f"{'met' if goals['latency_met'] else 'NOT met'} ({worst_latency(report)})",
    ]
    return "\n".join(lines)


def worst_latency(report: dict) -> str:
    """The team size with the highest p99 (a missing p99 counts as the worst), for the goal's line."""
    def p99(item: tuple[str, dict]) -> float:
        return math.inf if item[1]["latency_ms_p99"] is None else item[1]["latency_ms_p99"]

    count, row = max(report["vehicles"].items(), key=p99)
    at = row["latency_at_reports_per_s"]
    where = "" if at == report["goals"]["reports_per_s"] else f" at {fmt(at, 0)} reports/s"
    return (f"worst at {count} vehicles{where}: p50 {fmt(row['latency_ms_p50'])} ms, "
            f"p99 {fmt(row['latency_ms_p99'])} ms")


def write_json(report: dict, path: Path) -> None:
    """JSON with ``max_reports_per_s_no_loss``, ``latency_ms_p50``, ``latency_ms_p99`` and ``vehicles.<n>.*``."""
    path.write_text(json.dumps(report, indent=2) + "\n")
