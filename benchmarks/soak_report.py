"""``gcs-bench soak``'s report: the accounting, the late share, crashes, faults and memory, as JSON and as lines.

Built by :func:`benchmarks.soak.run_soak` from the daemon's final counters and
what the soak saw; the keys are those ``--json`` writes and docs/benchmarks.md
reads.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from benchmarks.daemon import _load_average
from protocols.messages import DaemonStatus

__all__ = ["POST_INGEST", "EPOCH_NS", "received", "late_share", "build_report", "format_report", "write_json"]

NS_PER_S = 1_000_000_000
EPOCH_NS = 1_000_000 * NS_PER_S
"""Wire stamp of the soak's simulation time zero."""
POST_INGEST = ("rejected.late", "rejected.diverged")
"""Rejections of reports ingest had accepted (counted twice otherwise)."""


def received(counters: dict[str, int]) -> int:
    """Samples the daemon took in: accepted, or rejected by ingest."""
    return sum(v for k, v in counters.items() if k.startswith("accepted.")) + sum(
        v for k, v in counters.items() if k.startswith("rejected.") and k not in POST_INGEST)


def build_report(options, soak, status: DaemonStatus, injected: dict[str, int], memory, baseline, end,
                 exit_codes: dict, command: str, note: str, load_start: str, wall_s: float, workdir: Path) -> dict:
    """The report's dict: ``options`` a :class:`~benchmarks.soak.SoakOptions`, ``soak`` the run's
    :class:`~benchmarks.soak_fleet.SoakFleet` (what it observed, the crashes and faults), ``status`` the daemon's final
    one, ``injected`` the count of each kind of bad sample put on the wire, ``memory`` the
    ``(wall s, daemon MB, planner MB)`` samples, ``baseline`` and ``end`` two of them."""
    counters = dict(status.counters)
    published = {"report": 0, "nav": 0, "truth": 0, **soak.observed}  # every kind, seen or not
    total = sum(published.values())
    taken_in = received(counters)
    dropped = {k.removeprefix("rejected."): v for k, v in sorted(counters.items()) if k.startswith("rejected.")}
    crashes = {"daemon": soak.crashes["daemon"], "router": soak.crashes["router"],
               "vehicle_processes": soak.crashes["vehicle_processes"],
               "planner_restarts": counters.get("planner_restarts", 0)}
    rss = [m for m in memory if m[1] is not None]
    simulated_s = (status.last_track_stamp_ns - EPOCH_NS) / NS_PER_S if status.last_track_stamp_ns else 0.0
    return {
        "command": command, "machine": note, "load_average": {"start": load_start, "end": _load_average()},
        "options": asdict(options), "wall_s": wall_s, "workdir": str(workdir),
        "simulated_s": simulated_s, "achieved_rate": simulated_s / wall_s if wall_s > 0 else 0.0,
        "published": {**published, "injected": sum(injected.values()), "total": total},
        "received": taken_in,
        "accepted": {k.removeprefix("accepted."): v for k, v in sorted(counters.items()) if k.startswith("accepted.")},
        "used_in_steps": counters.get("accepted.report", 0) - counters.get("rejected.late", 0),
        "dropped": dropped,
        "late": late_share(counters, injected.get("late", 0)),
        "lost": total - taken_in,
        "crashes": crashes, "crashes_total": sum(crashes.values()), "exit_codes": exit_codes,
        "errors": {k: v for k, v in counters.items() if k.startswith("errors.")},
        "faults": {"kills": soak.faults["kills"], "restarts": soak.faults["restarts"],
                   "silences": soak.faults["silences"], "silence_s": soak.silence_s,
                   "injected": dict(injected)},
        "decisions": counters.get("decisions", 0),
        "plans_superseded": counters.get("plans_superseded", 0),
        "steps_fused_only": counters.get("steps_fused_only", 0),
        "simulation": soak.simulation_lag(),
        "memory": {"daemon_rss_mb_start": baseline[1] if baseline else None, "daemon_rss_mb_end": end[1],
                   "daemon_rss_mb_max": max((m[1] for m in rss), default=None),
                   "daemon_rss_growth_mb": (end[1] - baseline[1]) if baseline and end[1] and baseline[1] else None,
                   "planner_rss_mb_start": baseline[2] if baseline else None, "planner_rss_mb_end": end[2],
                   "samples": [list(m) for m in memory[:: max(1, len(memory) // 200)]]},
        "counters": counters,
    }


def late_share(counters: dict[str, int], injected_late: int) -> dict:
    """The vehicles' reports taken in after their step had closed, out of the vehicles' reports accepted.

    The reports injected late on purpose are accepted by ingest and are late by design (a stamp 7.6
    steps back), so they are taken off both counts; ``share_with_injected`` counts every ``rejected.late``
    (an injected report that found its step still open was used, and is not among them)."""
    accepted, late = counters.get("accepted.report", 0), counters.get("rejected.late", 0)
    vehicles = max(accepted - injected_late, 0)
    own = max(late - injected_late, 0)
    return {"reports": own, "of": vehicles, "share": own / vehicles if vehicles else 0.0,
            "injected": injected_late, "share_with_injected": late / accepted if accepted else 0.0}


def format_report(report: dict) -> str:
    """A few lines: accounting, crashes, faults, memory."""
    published, memory, faults, late = report["published"], report["memory"], report["faults"], report["late"]
    simulation = report["simulation"]
    mb = (lambda v: "-" if v is None else f"{v:.1f}")
    options = report["options"]
    return "\n".join([
        f"soak: {report['command'] or 'gcs-bench soak'}",
        f"machine: {report['machine']}; load average {report['load_average']['start']} at start, "
        f"{report['load_average']['end']} at the end",
        f"{options['vehicles']} vehicles in {options['processes']} processes, {report['simulated_s']:.0f} of "
        f"{options['duration_s']:g} simulated s at {options['rate']:g}x in {report['wall_s']:.0f} s of wall time "
        f"({report['achieved_rate']:.1f}x achieved)",
        f"published on the wire: {published['total']:,} samples ({published.get('report', 0):,} reports, "
        f"{published.get('nav', 0):,} nav, {published.get('truth', 0):,} truth; {published['injected']:,} injected)",
        f"received by the daemon: {report['received']:,}; accepted {report['accepted']}; used in decision steps "
        f"{report['used_in_steps']:,} reports; dropped by reason {report['dropped']}",
        f"late: {late['share']:.2%} of the vehicles' reports ({late['reports']:,} of {late['of']:,} came after their "
        f"step had closed; {late['share_with_injected']:.2%} with the {late['injected']} injected late on purpose)",
        f"lost (published - received): {report['lost']}",
        f"crashes: {report['crashes_total']} {report['crashes']}; contained errors {report['errors'] or 'none'}",
        f"faults: {faults['kills']} vehicle processes killed ({faults['restarts']} restarted), "
        f"{faults['silences']} MAVLink silences ({faults['silence_s']:.0f} s), injected {faults['injected']}",
        f"daemon RSS: {mb(memory['daemon_rss_mb_start'])} MB at 10% -> {mb(memory['daemon_rss_mb_end'])} MB at the end "
        f"(growth {mb(memory['daemon_rss_growth_mb'])} MB, max {mb(memory['daemon_rss_mb_max'])}); planner process "
        f"{mb(memory['planner_rss_mb_start'])} -> {mb(memory['planner_rss_mb_end'])} MB",
        f"decisions: {report['decisions']:,} planned ({report['steps_fused_only']:,} steps fused only, a newer one "
        f"planned instead); "
        f"simulation steps started behind the wall schedule: {simulation['late_steps']:,} of "
        f"{simulation['steps']:,}; held for a slower vehicle process (lockstep): {simulation['held_steps']:,} "
        f"({simulation['held_s']:.1f} s of the processes' wall time)",
    ])


def write_json(report: dict, path: Path) -> None:
    """The report as JSON."""
    path.write_text(json.dumps(report, indent=2) + "\n")
