"""``gcs-bench sharing``: paired runs over seeds of each mode, the table, the paired tests, the JSON.

Per mode, the means over runs of: each target's in-field steps averaged over the
targets (``target_steps_mean``) and their minimum over the targets (``target_steps_min``,
the starved target), each UAV's steps with some target in its field, and the GOSPA.
``plan_ms_median`` and ``plan_ms_p99`` pool every decision of every run. Each planned
mode is compared, seed by seed, with every other mode by the paired Wilcoxon
signed-rank test (:func:`benchmarks.urban_report.paired_p`) of ``target_steps_min``,
``target_steps_mean`` and ``gospa``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from itertools import combinations
from pathlib import Path

import numpy as np

from benchmarks import sharing
from benchmarks.urban_report import paired_p

__all__ = ["PAIRED", "run_benchmark", "format_report", "write_json"]

PAIRED = ("target_steps_min", "target_steps_mean", "gospa")


def run_benchmark(config: sharing.SharingConfig, runs: int, seed: int, modes: Sequence[str] = sharing.MODES,
                  progress: Callable[[str], None] = lambda _: None) -> dict:
    """Every mode on the seeds ``seed .. seed + runs - 1``; the report as a dict."""
    import msgspec

    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario("wang2012_urban")
    world = build_world(scenario)
    team = msgspec.structs.replace(scenario, vehicles=scenario.vehicles[:len(sharing.mt.ORBITS)])
    per_seed: list[dict] = []
    seconds: dict[str, list[float]] = {m: [] for m in modes}
    for run in range(runs):
        row = {}
        for mode in modes:
            result = sharing.fly_run(mode, world, team, seed + run, config)
            seconds[mode].extend(result.plan_seconds)
            row[mode] = {"target_steps": result.target_steps.tolist(), "uav_steps": result.uav_steps.tolist(),
                         "target_steps_mean": float(result.target_steps.mean()),
                         "target_steps_min": int(result.target_steps.min()), "gospa": result.gospa_m}
        per_seed.append({"seed": seed + run, "modes": row})
        progress(f"seed {seed + run}: " + ", ".join(
            f"{m} min {r['target_steps_min']} mean {r['target_steps_mean']:.1f} GOSPA {r['gospa']:.1f}"
            for m, r in row.items()))
    summary = {m: _summary(m, per_seed, seconds[m]) for m in modes}
    scene = config.scene
    return {"modes": summary, "paired_p": _paired(per_seed, modes),
            "config": {"targets": scene.targets, "steps": scene.steps, "pd": scene.pd, "clutter": scene.clutter,
                       "warm_up": scene.warm_up, "scored_steps": scene.steps - min(scene.warm_up, scene.steps - 1),
                       "starvation_s": config.starvation_s, "forget_s": sharing.FORGET_S, "uavs": len(team.vehicles),
                       "runs": runs, "seed": seed},
            "per_seed": per_seed}


def _summary(mode: str, per_seed: Sequence[dict], seconds: Sequence[float]) -> dict:
    rows = [s["modes"][mode] for s in per_seed]
    ms = 1e3 * np.asarray(seconds)
    return {"target_steps_mean": float(np.mean([r["target_steps_mean"] for r in rows])),
            "target_steps_min": float(np.mean([r["target_steps_min"] for r in rows])),
            "uav_steps": [float(x) for x in np.mean([r["uav_steps"] for r in rows], axis=0)],
            "gospa": float(np.mean([r["gospa"] for r in rows])),
            "plan_ms_median": float(np.median(ms)) if ms.size else None,
            "plan_ms_p99": float(np.percentile(ms, 99)) if ms.size else None}


def _paired(per_seed: Sequence[dict], modes: Sequence[str]) -> dict:
    """``{"a_vs_b": {figure: p}}`` for every pair of modes."""
    out = {}
    for a, b in combinations(modes, 2):
        out[f"{a}_vs_{b}"] = {f: paired_p([s["modes"][a][f] for s in per_seed], [s["modes"][b][f] for s in per_seed])
                              if len(per_seed) >= 2 else float("nan") for f in PAIRED}
    return out


def format_report(report: dict) -> str:
    """The report as markdown tables."""
    c = report["config"]
    lines = [f"gcs-bench sharing: {c['targets']} targets, {c['uavs']} UAVs, seeds {c['seed']}-{c['seed'] + c['runs'] - 1}, "
             f"{c['scored_steps']} scored steps per run, pd {c['pd']:g}, clutter {c['clutter']:g}", "",
             "| mode | target in field, mean over targets | worst target | per UAV | GOSPA (m) | plan ms median | p99 |",
             "|---|---|---|---|---|---|---|"]
    for mode, s in report["modes"].items():
        per_uav = " / ".join(f"{x:.1f}" for x in s["uav_steps"])
        ms = "-" if s["plan_ms_median"] is None else f"{s['plan_ms_median']:.0f}"
        p99 = "-" if s["plan_ms_p99"] is None else f"{s['plan_ms_p99']:.0f}"
        lines.append(f"| {mode} | {s['target_steps_mean']:.1f} | {s['target_steps_min']:.1f} | {per_uav} | "
                     f"{s['gospa']:.1f} | {ms} | {p99} |")
    lines += ["", "| paired Wilcoxon p | worst target | mean over targets | GOSPA |", "|---|---|---|---|"]
    for pair, p in report["paired_p"].items():
        lines.append(f"| {pair.replace('_vs_', ' vs ')} | " + " | ".join(f"{p[f]:.2g}" for f in PAIRED) + " |")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")
