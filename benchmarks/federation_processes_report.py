"""``gcs-bench federation --processes``'s report: per member and over the members, printed and as JSON.

The goal checked: every member decides each step within its step (its plan on the wire within the step
after the step's last report) and publishes under 50 kB/s on its federation key
(:mod:`benchmarks.federation_processes` says how each figure is taken).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from benchmarks.daemon import machine_note
from benchmarks.federation_processes import (SCENARIO, Observer, ProcessesConfig, counter_deltas,
                                             step_figures)
from gcs.config import Scenario

__all__ = ["build_report", "format_report", "write_json", "GOAL_BYTES_PER_S"]

GOAL_BYTES_PER_S = 50_000.0


def build_report(config: ProcessesConfig, observer: Observer, window: tuple[int, int, int], before: dict,
                 after: dict, seen: dict[str, int], team_bytes_per_s: dict[str, float], load: tuple, codes: dict,
                 scenario: Scenario) -> dict:
    """The report (module docstring) from what the observer collected over ``window`` (first, end, step ns)."""
    members = []
    for member in observer.members:
        figures = step_figures(observer, member, window)
        members.append({"member": member, "others_seen": seen[member], **figures,
                        "team_bytes_per_s": team_bytes_per_s[member],
                        "counters": counter_deltas(before[member], after[member])})
    shared = [m["federation_bytes_per_s"] for m in members]
    medians = [m["decision_ms"]["median"] for m in members if m["decision_ms"]["n"]]
    p99s = [m["decision_ms"]["p99"] for m in members if m["decision_ms"]["n"]]
    step_s = window[2] / 1e9
    return {
        "config": {"members": config.members, "uavs_per_member": config.uavs_per_member, "steps": config.steps,
                   "step_s": step_s, "fusion": config.fusion, "range_m": config.range_m, "seed": config.seed,
                   "scenario": SCENARIO, "cars": 1 + len(scenario.targets), "processes": True, "central": False},
        "machine": {"note": machine_note(), "niceness": os.nice(0),
                    "load_average_start": list(load[0]), "load_average_end": list(load[1])},
        "members": members,
        "summary": {
            "decision_ms_median_max": max(medians, default=None),
            "decision_ms_p99_max": max(p99s, default=None),
            "decision_ms_max": max((m["decision_ms"]["max"] for m in members if m["decision_ms"]["n"]), default=None),
            "steps": sum(m["steps"] for m in members),
            "over_step": sum(m["over_step"] for m in members),
            "planned": sum(m["planned"] for m in members),
            "undecided": sum(m["undecided"] for m in members),
            "fused_only": sum(m["counters"]["steps_fused_only"] for m in members),
            "plans_superseded": sum(m["counters"]["plans_superseded"] for m in members),
            "federation_bytes_per_s_max": max(shared), "federation_bytes_per_s_mean": sum(shared) / len(shared),
            "every_member_sees_all": all(m["others_seen"] == config.members - 1 for m in members),
            "goal_met": (all(m["over_step"] == m["undecided"] == m["counters"]["steps_fused_only"]
                             == m["counters"]["plans_superseded"] == 0 for m in members)
                         and max(shared) < GOAL_BYTES_PER_S),
        },
        "exit_codes": codes,
    }


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f}"


def format_report(report: dict) -> str:
    c, s, machine = report["config"], report["summary"], report["machine"]
    load = "/".join(f"{x:.2f}" for x in machine["load_average_start"])
    load_end = "/".join(f"{x:.2f}" for x in machine["load_average_end"])
    lines = [f"federation --processes: {c['members']} members x {c['uavs_per_member']} UAVs, {c['steps']} steps of "
             f"{c['step_s']:g} s in real time, {c['scenario']} ({c['cars']} cars), sensor range {c['range_m']:g} m, "
             f"fusion {c['fusion']}, seed {c['seed']}",
             f"one gcs router, {c['members']} `gcs run` daemons and {c['members']} `sim-vehicles run` teams on "
             f"127.0.0.1; no central daemon (--no-central implied)",
             f"machine: {machine['note']}; every process at niceness {machine['niceness']}; load average 1/5/15 min "
             f"{load} at start, {load_end} at end", "",
             "| member | others seen | steps (planned) | decision ms median / p99 / max | over the step | undecided "
             "| picture ms median | federation B/s | rest of daemon B/s |",
             "|---|---|---|---|---|---|---|---|---|"]
    for m in report["members"]:
        d = m["decision_ms"]
        lines.append(f"| {m['member']} | {m['others_seen']} | {m['steps']} ({m['planned']}) | {_ms(d['median'])} / {_ms(d['p99'])} / "
                     f"{_ms(d['max'])} | {m['over_step']} | {m['undecided']} | "
                     f"{_ms(m['picture_ms']['median'])} | {m['federation_bytes_per_s']:.0f} | "
                     f"{m['team_bytes_per_s']:.0f} |")
    lines += ["", f"decision (a step's last report to its first plan, or to its picture when it had nothing to plan "
                  f"for; both on the wire): median at most "
                  f"{_ms(s['decision_ms_median_max'])} ms, p99 at most {_ms(s['decision_ms_p99_max'])} ms, max "
                  f"{_ms(s['decision_ms_max'])} ms over the members",
              f"steps decided over their {c['step_s']:g} s: {s['over_step']} of {s['steps']} ({s['planned']} planned); "
              f"undecided: {s['undecided']}; the daemons' counters: {s['fused_only']} steps fused only, "
              f"{s['plans_superseded']} plans superseded",
              f"federation traffic per member: max {s['federation_bytes_per_s_max'] / 1e3:.2f} kB/s, mean "
              f"{s['federation_bytes_per_s_mean'] / 1e3:.2f} kB/s (goal < 50 kB/s)",
              f"every member sees all the others: {'yes' if s['every_member_sees_all'] else 'no'}; goal met: "
              f"{'yes' if s['goal_met'] else 'no'}"]
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=1))
