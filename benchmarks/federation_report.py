"""``gcs-bench federation``'s runs over paired seeds, their comparison, and the printed report.

Each seed flies the federation (:func:`benchmarks.federation.fly_federation`) and, unless
``--no-central``, the central daemon (:func:`benchmarks.federation.fly_central`) on the same scene.
GOSPA is compared per seed (paired Wilcoxon signed-rank test); the goals of the federation are
checked against their figures: GOSPA within 10% of the central daemon's, at most one id change per
target per run, NEES inside its band in at least 90% of the steps, hand-overs within 2 s, a dead
member's targets taken up within 5 s, each member deciding within its step and publishing under
50 kB/s.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from benchmarks.federation import FederationConfig, RunScores, fly_central, fly_federation

__all__ = ["run_benchmark", "format_report", "write_json"]


def _spread(values: list[float]) -> dict:
    if not values:
        return {"n": 0}
    a = np.asarray(values, dtype=float)
    return {"n": len(a), "median": float(np.median(a)), "p90": float(np.percentile(a, 90)), "max": float(a.max())}


def _paired_p(a: list[float], b: list[float]) -> float | None:
    differences = np.asarray(a) - np.asarray(b)
    if len(differences) < 2 or not np.any(differences):
        return None
    return float(wilcoxon(a, b).pvalue)


def run_benchmark(config: FederationConfig, runs: int, seed: int, central: bool = True,
                  progress: Callable[[str], None] = lambda _: None) -> dict:
    """``runs`` paired seeds from ``seed``; the report as a dict."""
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    base = load_scenario("wang2012_urban")
    world = build_world(base)
    federated: list[RunScores] = []
    centralised: list[RunScores] = []
    for run in range(runs):
        federated.append(fly_federation(world, base, seed + run, config))
        line = f"seed {seed + run}: federation GOSPA {federated[-1].gospa_m:.1f} m"
        if central:
            centralised.append(fly_central(world, base, seed + run, config))
            line += f", central {centralised[-1].gospa_m:.1f} m"
        progress(line)
    return {"config": {"members": config.members, "uavs_per_member": config.uavs_per_member,
                       "targets": config.scene.targets, "steps": config.scene.steps, "pd": config.scene.pd,
                       "clutter": config.scene.clutter, "fusion": config.fusion, "kill": config.kill},
            "seeds": list(range(seed, seed + runs)),
            "federation": _summary(federated), "central": _summary(centralised) if central else None,
            "gospa_p": _paired_p([r.gospa_m for r in federated], [r.gospa_m for r in centralised]) if central else None,
            "runs": {"federation": [asdict(r) for r in federated], "central": [asdict(r) for r in centralised]}}


def _summary(runs: list[RunScores]) -> dict:
    ms = [1e3 * s for r in runs for s in r.decision_seconds]
    return {
        "gospa_m": float(np.mean([r.gospa_m for r in runs])),
        "gospa_per_seed": [r.gospa_m for r in runs],
        "id_changes_max": max(r.id_changes_max for r in runs),
        "id_changes_mean": float(np.mean([r.id_changes_mean for r in runs])),
        "id_swaps_mean": float(np.mean([r.id_swaps for r in runs])),
        "nees_inside": float(np.mean([r.nees_inside for r in runs])),
        "nees_fused_mean": float(np.nanmean([r.nees_fused_mean for r in runs])) if runs else None,
        "hand_over_s": _spread([s for r in runs for s in r.hand_over_s]),
        "hand_overs_missed": sum(r.hand_overs_missed for r in runs),
        "hand_over_claim_s": _spread([s for r in runs for s in r.hand_over_claim_s]),
        "take_up_claim_s": _spread([s for r in runs for s in r.take_up_claim_s]),
        "take_up_held_s": _spread([s for r in runs for s in r.take_up_held_s]),
        "bytes_per_s_max": max((b for r in runs for b in r.bytes_per_s), default=0.0),
        "decision_ms": {"median": float(np.median(ms)), "p99": float(np.percentile(ms, 99)), "max": float(max(ms))},
    }


def _fmt_spread(spread: dict) -> str:
    if spread["n"] == 0:
        return "none"
    return f"{spread['median']:.1f} / {spread['p90']:.1f} / {spread['max']:.1f} s (n {spread['n']})"


def format_report(report: dict) -> str:
    c = report["config"]
    lines = [f"federation: {c['members']} members x {c['uavs_per_member']} UAVs, {c['targets']} targets, "
             f"{c['steps']} steps, pd {c['pd']}, clutter {c['clutter']}, fusion {c['fusion']}"
             + (f", member {c['kill'][0]} killed at step {c['kill'][1]}" if c["kill"] else "")
             + f"; seeds {report['seeds'][0]}..{report['seeds'][-1]}",
             "", "| | GOSPA (m) | id changes max / mean | id swaps | NEES inside band | decision ms median / p99 |",
             "|---|---|---|---|---|---|"]
    for name in ("federation", "central"):
        s = report[name]
        if s is None:
            continue
        lines.append(f"| {name} | {s['gospa_m']:.1f} | {s['id_changes_max']} / {s['id_changes_mean']:.2f} | "
                     f"{s['id_swaps_mean']:.1f} | {100 * s['nees_inside']:.1f}% | "
                     f"{s['decision_ms']['median']:.1f} / {s['decision_ms']['p99']:.1f} |")
    f = report["federation"]
    lines.append("")
    if report["central"] is not None:
        ratio = f["gospa_m"] / report["central"]["gospa_m"]
        p = report["gospa_p"]
        lines.append(f"GOSPA federation / central: {ratio:.3f} (paired Wilcoxon p = "
                     f"{'n/a' if p is None else f'{p:.3f}'})")
    lines.append(f"hand-over, to the next member's own track with the id kept, median / p90 / max: "
                 f"{_fmt_spread(f['hand_over_s'])}; not completed: {f['hand_overs_missed']}")
    lines.append(f"hand-over, to the next member planning for it: {_fmt_spread(f['hand_over_claim_s'])}")
    if c["kill"]:
        lines.append(f"dead member's targets claimed by another: {_fmt_spread(f['take_up_claim_s'])}; "
                     f"held by another: {_fmt_spread(f['take_up_held_s'])}")
    if f["nees_fused_mean"] is not None and np.isfinite(f["nees_fused_mean"]):
        lines.append(f"mean NEES of the estimates fused from two or more members: {f['nees_fused_mean']:.2f} "
                     "(2 when consistent)")
    lines.append(f"traffic: at most {f['bytes_per_s_max'] / 1e3:.1f} kB/s per member")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=1))
