"""``gcs-bench urban --gps-denied``: the closed loop with the vehicles' own navigation in GPS-denied zones.

Every requested planner and navigation (:data:`benchmarks.urban_scene.NAVIGATIONS`: the true positions,
the vehicles' own reported navigation, the engine's SKF on their nav reports) runs on the same seeds
(same city, target path, sensor noise, GPS and INS draws).
The zones are the scenario's ``[[gps_denied]]`` polygons; a scenario without any
gets :data:`DEFAULT_ZONE`, the 1.5 km square about the target's start, where the
UAVs spend most of their time. Reported per planner and navigation: the target's
fused RMSE over the run and over the outage steps (steps at which at least one
UAV has no fix), the UAVs' own horizontal navigation error over their steps
without a fix, the outage steps and the observations; and, paired, in how many
runs the engine's SKF beat the reported positions on the outage RMSE.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import msgspec
import numpy as np

from benchmarks.urban import RunRecord, run_closed_loop
from benchmarks.urban_scene import NAVIGATIONS as NAVIGATION_MODES
from gcs.config import Scenario
from gcs.config.simulation import GpsDeniedZone
from gcs.core.world import World

__all__ = ["NAVIGATION_MODES", "DEFAULT_ZONE", "with_gps_denied", "run_benchmark", "format_report", "write_json"]

DEFAULT_ZONE = GpsDeniedZone(name="centre", polygon_enu_m=[(750.0, 750.0), (2250.0, 750.0), (2250.0, 2250.0),
                                                           (750.0, 2250.0)])
"""GPS-denied square of 1.5 km about wang2012's target start (1500, 1500), for scenarios that declare none."""


def with_gps_denied(scenario: Scenario) -> Scenario:
    """The scenario with its own GPS-denied zones, or :data:`DEFAULT_ZONE` when it has none."""
    return scenario if scenario.gps_denied else msgspec.structs.replace(scenario, gps_denied=[DEFAULT_ZONE])


def _rms(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def summarise(records: Sequence[RunRecord]) -> dict:
    """Pooled over runs: target RMSE (all steps, outage steps), navigation error without fix, outages, observations."""
    outage = [~r.gps_fix.all(axis=1) for r in records]
    return {
        "runs": len(records),
        "rmse_m": _rms(np.concatenate([r.errors_m for r in records])),
        "rmse_outage_m": _rms(np.concatenate([r.errors_m[o] for r, o in zip(records, outage)])),
        "nav_rmse_outage_m": _rms(np.concatenate([r.nav_error_m[~r.gps_fix] for r in records])),
        "nav_rmse_m": _rms(np.concatenate([r.nav_error_m.ravel() for r in records])),
        "outage_steps_mean": float(np.mean([o.sum() for o in outage])),
        "seen_any_mean": float(np.mean([r.seen_any for r in records])),
        "steps": int(records[0].seen.shape[0]),
    }


def run_benchmark(scenario: Scenario, world: World, runs: int, seed: int, planners: Sequence[str],
                  navigations: Sequence[str] = NAVIGATION_MODES, duration_s: float | None = None,
                  motion: str | None = None, progress: Callable[[str], None] | None = None) -> dict:
    """Paired closed-loop runs of every planner x navigation; the report as a dict."""
    say = progress or (lambda _msg: None)
    denied = with_gps_denied(scenario)
    records: dict[str, dict[str, list[RunRecord]]] = {p: {n: [] for n in navigations} for p in planners}
    for run in range(runs):
        for planner in planners:
            for navigation in navigations:
                record = run_closed_loop(denied, world, planner, seed + run, duration_s=duration_s, motion=motion,
                                         navigation=navigation)
                records[planner][navigation].append(record)
                say(f"run {run + 1}/{runs} {planner} {navigation}: RMSE {record.rmse_m:.1f} m, "
                    f"seen {record.seen_any}/{record.seen.shape[0]}")
    report = {"scenario": denied.name, "runs": runs, "seed": seed, "motion": motion or denied.target.motion,
              "gps_denied": [{"name": z.name, "polygon_enu_m": [list(p) for p in z.polygon_enu_m]}
                             for z in denied.gps_denied],
              "planners": {}}
    for planner, by_nav in records.items():
        entry = {"navigation": {nav: summarise(recs) for nav, recs in by_nav.items()}}
        if "skf" in by_nav and "reported" in by_nav:
            def outage_rmse(r: RunRecord) -> float:
                return _rms(r.errors_m[~r.gps_fix.all(axis=1)])
            wins = sum(outage_rmse(s) < outage_rmse(g) for s, g in zip(by_nav["skf"], by_nav["reported"]))
            entry["skf_beats_reported_runs"] = int(wins)
        report["planners"][planner] = entry
    return report


def format_report(report: dict) -> str:
    """One table per planner."""
    zones = ", ".join(z["name"] for z in report["gps_denied"])
    lines = [f"urban benchmark with GPS-denied zones ({zones}): {report['scenario']}, {report['runs']} paired runs "
             f"from seed {report['seed']}, target motion {report['motion']}"]
    for planner, entry in report["planners"].items():
        lines += ["", f"planner {planner}",
                  f"{'navigation':<13}{'target RMSE m':>15}{'in outages':>12}{'nav RMSE no fix m':>19}"
                  f"{'outage steps':>14}{'seen by any':>13}"]
        for nav, m in entry["navigation"].items():
            lines.append(f"{nav:<13}{m['rmse_m']:>15.2f}{m['rmse_outage_m']:>12.2f}{m['nav_rmse_outage_m']:>19.2f}"
                         f"{m['outage_steps_mean']:>10.1f}/{m['steps']:<3}{m['seen_any_mean']:>9.1f}/{m['steps']}")
        if "skf_beats_reported_runs" in entry:
            lines.append(f"skf below reported in outages in {entry['skf_beats_reported_runs']} of {report['runs']} "
                         "runs")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """JSON with ``planners.<planner>.navigation.<nav>.{rmse_m, rmse_outage_m, nav_rmse_outage_m, ...}``."""
    path.write_text(json.dumps(report, indent=2) + "\n")
