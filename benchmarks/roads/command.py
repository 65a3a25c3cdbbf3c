"""``gcs-bench roads``: the road trackers against the scenario's estimator, open loop, paired seeds.

Example (the figures of docs/road_tracking.md)::

    nice gcs-bench roads --seeds 20 --out road_tracking.json

runs every estimator of :data:`benchmarks.roads.estimators.ESTIMATORS` on seeds
0..19 of each scenario of :data:`benchmarks.roads.scene.SCENARIOS` and prints a
Markdown table per scenario (figures: :mod:`benchmarks.roads.metrics`); ``--out``
also writes them as JSON.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from gcs.cli_errors import UsageError
from gcs.config import ScenarioError
from benchmarks.roads.estimators import ESTIMATORS, run_estimator
from benchmarks.roads.metrics import longest_unseen, paired, run_figures, summary
from benchmarks.roads.scene import SCENARIOS, load_scene, simulate

BASELINE = "duif"


def _one(job: tuple[str, int, tuple[str, ...], float | None]) -> tuple[str, int, int, float, dict]:
    name, seed, estimators, duration = job
    scene = load_scene(name)
    run = simulate(scene, seed, duration)
    figures = {e: run_figures(run, run_estimator(e, scene, run)) for e in estimators}
    return name, seed, longest_unseen(run), float(run.seen.any(axis=1).mean()), figures


def _table(name: str, results: dict, estimators: Sequence[str]) -> str:
    lines = [f"### {name}", "",
             f"seen by any UAV: {results['seen_share']:.0%} of steps; longest unseen stretch: median "
             f"{results['unseen_median']:.0f} s, max {results['unseen_max']} s", "",
             "| estimator | RMSE pooled m | per-run RMSE mean m | p (Wilcoxon vs duif) | better seeds | p95 m | max m "
             "| runs >50 m | runs >100 m | steps >50 m | steps >100 m | NEES in 95% band | ms/step median (p10-p90) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for e in estimators:
        s, p = results["summary"][e], results["paired"].get(e)
        test = f"{p['p']:.2g} | {p['better']}/{p['runs']}" if p else "- | -"
        lines.append(f"| `{e}` | {s['rmse_pooled_m']:.1f} | {s['rmse_mean_m']:.1f} | {test} | {s['p95_m']:.1f} | "
                     f"{s['max_m']:.0f} | {s['runs_over_50']} | {s['runs_over_100']} | {s['steps_over_50']} | "
                     f"{s['steps_over_100']} | {s['nees_inside']:.2f} | {s['ms_median']:.2f} "
                     f"({s['ms_p10']:.2f}-{s['ms_p90']:.2f}) |")
    others = [e for e in estimators if e != BASELINE]
    pairs = [(a, b) for i, a in enumerate(others) for b in others[i + 1:]]
    if pairs:
        lines += ["", "| paired per-run RMSE | p (Wilcoxon) | seeds the first is better |", "|---|---|---|"]
        for a, b in pairs:
            p = results["between"][f"{a} vs {b}"]
            lines.append(f"| `{a}` vs `{b}` | {p['p']:.2g} | {p['better']}/{p['runs']} |")
    return "\n".join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of the comparison."""
    parser.add_argument("--seeds", type=int, default=20, help="seeds 0..N-1 per scenario (default 20)")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS), help="comma-separated shipped scenarios")
    parser.add_argument("--estimators", default=",".join(ESTIMATORS),
                        help="comma-separated, of: " + ", ".join(ESTIMATORS))
    parser.add_argument("--duration", type=float, default=None, help="seconds per run (default: the scenario's)")
    parser.add_argument("--workers", type=int, default=1, help="processes (timing is cleanest with 1)")
    parser.add_argument("--out", default=None, help="write the figures as JSON here")


def check(args: argparse.Namespace) -> None:
    """UsageError for an unknown estimator, no seeds, or a scenario that does not load or has no street grid."""
    unknown = [e for e in args.estimators.split(",") if e not in ESTIMATORS]
    if unknown or args.seeds < 1:
        raise UsageError(f"bad --estimators {unknown} or --seeds {args.seeds}; use some of {', '.join(ESTIMATORS)} "
                         "and --seeds >= 1")
    for name in args.scenarios.split(","):
        try:
            scene = load_scene(name)
        except ScenarioError as error:
            raise UsageError(f"--scenarios {name!r}: {error}") from None
        if scene.world.streets is None:
            raise UsageError(f"--scenarios {name!r} has no street grid for the car; use a generated city, e.g. "
                             f"{', '.join(SCENARIOS)}")


def run(args: argparse.Namespace) -> int:
    """Check the options, run every estimator on every seed of every scenario, print the tables, write --out."""
    check(args)
    estimators = tuple(args.estimators.split(","))
    jobs = [(name, seed, estimators, args.duration) for name in args.scenarios.split(",") for seed in range(args.seeds)]
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            done = list(pool.map(_one, jobs))
    else:
        done = [_one(job) for job in jobs]
    report = {}
    for name in args.scenarios.split(","):
        rows = [d for d in done if d[0] == name]
        per = {e: [r[4][e] for r in rows] for e in estimators}
        report[name] = {
            "seeds": [r[1] for r in rows], "seen_share": float(np.mean([r[3] for r in rows])),
            "unseen_median": float(np.median([r[2] for r in rows])), "unseen_max": int(max(r[2] for r in rows)),
            "summary": {e: summary(per[e]) for e in estimators},
            "paired": {e: paired(per[e], per[BASELINE]) for e in estimators if e != BASELINE and BASELINE in per},
            "between": {f"{a} vs {b}": paired(per[a], per[b])
                        for i, a in enumerate(estimators) for b in estimators[i + 1:] if BASELINE not in (a, b)},
            "per_run_rmse_m": {e: [f["rmse_m"] for f in per[e]] for e in estimators},
        }
        print(_table(name, report[name], estimators), "\n", flush=True)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as handle:
            json.dump(report, handle, indent=1)
    return 0

