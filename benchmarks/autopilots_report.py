"""``gcs-bench autopilots``: each autopilot personality flies the same scenario on paired seeds.

For every personality (and steering encoding) the closed loop of
:func:`benchmarks.autopilots.fly` runs on the same seeds. The report gives, per
personality, the median course error against the planned path (pooled over
every vehicle and steering instant after the settle), seen-by-any and per UAV
(means), the fused position RMSE (pooled over every step with a track), and
beside them the paired Wilcoxon signed-rank p of seen-by-any against the
``ideal`` airframe, and the ratios to it that the goals are set on
(seen-by-any and RMSE within 5%). ``--identify`` prints each personality's
course loop as measured from step responses, beside the one the daemon steers
with (:data:`gcs.core.steering.COURSE_LOOPS`).

JSON: ``personalities.<name>.{course_error_deg_median, course_error_deg_p90, course_error_deg_max,
turn_rate_achieved_deg_s_median, turn_rate_planned_deg_s, turn_rate_ratio, seen_any_mean, rmse_m,
seen_per_uav_mean, seen_any, p_vs_ideal, seen_any_ratio, rmse_ratio}`` (the course following of
:mod:`benchmarks.course_following`), and
``steering_pursuit.<name>`` likewise when the pursuit encoding is compared.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path

import numpy as np

from benchmarks.autopilots import FlightRecord, fly, identify
from benchmarks.course_following import course_following
from benchmarks.urban_report import paired_p
from gcs.core.steering import COURSE_LOOPS

__all__ = ["PERSONALITIES", "format_report", "run_benchmark", "summarise", "write_json"]

PERSONALITIES = ("ideal", "arduplane", "px4")
REFERENCE = "ideal"


@lru_cache(maxsize=4)
def _loaded(scenario: str):
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    loaded = load_scenario(scenario)
    return loaded, build_world(loaded)


def _fly(job: tuple[str, str, str, int, float | None]) -> FlightRecord:
    logging.getLogger("sim_vehicles").setLevel(logging.WARNING)  # every mode switch of every flight is noise here
    scenario_name, personality, steering, seed, duration_s = job
    scenario, world = _loaded(scenario_name)
    return fly(scenario, world, personality, seed, duration_s=duration_s, steering=steering)


def summarise(records: Sequence[FlightRecord]) -> dict:
    """Means over the flights of one personality; course following (:func:`benchmarks.course_following.
    course_following`) and position errors pooled, and each run's RMSE."""
    errors = np.concatenate([r.errors_m for r in records])
    errors = errors[np.isfinite(errors)]
    samples = [vehicle for r in records for vehicle in r.steering_samples]
    return {
        "runs": len(records),
        "seeds": [r.seed for r in records],
        "steps": int(records[0].seen.shape[0]),
        **course_following(samples, min(r.max_turn_rate_rad_s for r in records)),
        "rmse_m_per_run": [_rmse(r.errors_m) for r in records],
        "seen_any": [r.seen_any for r in records],
        "seen_any_mean": float(np.mean([r.seen_any for r in records])),
        "seen_per_uav_mean": [float(x) for x in np.mean([r.seen_per_uav for r in records], axis=0)],
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else float("nan"),
    }


def _rmse(errors: np.ndarray) -> float:
    scored = errors[np.isfinite(errors)]
    return float(np.sqrt(np.mean(scored**2))) if scored.size else float("nan")


def _compare(summaries: dict[str, dict], reference: dict | None) -> None:
    if reference is None:
        return
    for name, summary in summaries.items():
        summary["p_vs_ideal"] = paired_p(summary["seen_any"], reference["seen_any"])
        summary["seen_any_ratio"] = summary["seen_any_mean"] / reference["seen_any_mean"]
        summary["rmse_ratio"] = summary["rmse_m"] / reference["rmse_m"]


def run_benchmark(scenario_name: str, runs: int, seed: int, personalities: Sequence[str] = PERSONALITIES,
                  duration_s: float | None = None, compare_pursuit: bool = False, workers: int = 1,
                  identify_loops: bool = False, progress: Callable[[str], None] | None = None) -> dict:
    """Paired flights of every personality (and, with ``compare_pursuit``, the pursuit encoding); the report."""
    say = progress or (lambda _msg: None)
    scenario, _ = _loaded(scenario_name)
    encodings = ["lead"] + (["pursuit"] if compare_pursuit else [])
    jobs = [(scenario_name, p, steering, seed + run, duration_s)
            for steering in encodings for p in personalities for run in range(runs)]
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            records = list(pool.map(_fly, jobs))
    else:
        records = [_fly(job) for job in jobs]
    for job, record in zip(jobs, records):
        say(f"{job[1]} ({job[2]}) seed {job[3]}: seen by any {record.seen_any}, per UAV {record.seen_per_uav}, "
            f"course error median {record.course_error_deg_median:.2f} deg")
    by = {(steering, p): [r for j, r in zip(jobs, records) if j[1] == p and j[2] == steering]
          for steering in encodings for p in personalities}
    lead = {p: summarise(by[("lead", p)]) for p in personalities}
    _compare(lead, lead.get(REFERENCE))
    report = {"scenario": scenario.name, "runs": runs, "seed": seed,
              "duration_s": duration_s or scenario.time.duration_s, "personalities": lead}
    if compare_pursuit:
        pursuit = {p: summarise(by[("pursuit", p)]) for p in personalities}
        _compare(pursuit, lead.get(REFERENCE))
        report["steering_pursuit"] = pursuit
    if identify_loops:
        report["course_loops"] = {p: {"identified": asdict(identify(p)),
                                      "steered_with": asdict(COURSE_LOOPS[p]) if p in COURSE_LOOPS else None}
                                  for p in personalities if p != "px4"}
    return report


def _rows(summaries: dict[str, dict], label: str) -> list[str]:
    out = []
    for name, s in summaries.items():
        per_uav = "/".join(f"{x:.1f}" for x in s["seen_per_uav_mean"])
        versus = "" if "p_vs_ideal" not in s else (
            f" | {s['seen_any_ratio']:.3f} | {s['rmse_ratio']:.3f} | {s['p_vs_ideal']:.3g}")
        out.append(f"| {name} ({label}) | {s['course_error_deg_median']:.2f} | {s['course_error_deg_p90']:.2f} | "
                   f"{s['turn_rate_achieved_deg_s_median']:.2f} / {s['turn_rate_planned_deg_s']:.2f} "
                   f"({100 * s['turn_rate_ratio']:.0f}%) | {s['seen_any_mean']:.1f}/{s['steps']} | {per_uav} | "
                   f"{s['rmse_m']:.1f}{versus} |")
    return out


def format_report(report: dict) -> str:
    """The report as markdown tables."""
    lines = [f"gcs-bench autopilots: {report['scenario']}, {report['runs']} paired seeds from {report['seed']}, "
             f"{report['duration_s']:.0f} s each", "",
             "| autopilot (steering) | course error median (deg) | p90 (deg) | turn rate at the limit, achieved / "
             "planned (deg/s) | seen by any | per UAV | RMSE (m) | seen vs ideal | RMSE vs ideal | p vs ideal |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += _rows(report["personalities"], "lead")
    lines += _rows(report.get("steering_pursuit", {}), "pursuit")
    loops = report.get("course_loops")
    if loops:
        lines += ["", "| autopilot | K identified (1/s) | tau identified (s) | max rate (deg/s) | K, tau steered with |",
                  "|---|---|---|---|---|"]
        for name, entry in loops.items():
            found, used = entry["identified"], entry["steered_with"]
            steered = "-" if used is None else f"{used['gain_per_s']:.3f}, {used['lag_s']:.3f}"
            lines.append(f"| {name} | {found['gain_per_s']:.3f} | {found['lag_s']:.3f} | "
                         f"{np.degrees(found['max_turn_rate_rad_s']):.2f} | {steered} |")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")
