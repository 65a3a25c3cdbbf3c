"""``gcs bench ...``: argument parsing and output for each benchmark.

Each benchmark module computes; this module parses arguments, prints the
tables (progress goes to stderr) and writes ``--json`` files.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gcs.bench import PLANNERS


def _progress(message: str) -> None:
    print(f"  ... {message}", file=sys.stderr, flush=True)


def _cmd_estimation(args: argparse.Namespace) -> int:
    from gcs.bench import estimation

    report = estimation.run_benchmark(
        runs=args.runs, seed=args.seed, steps=args.steps, table_runs=args.table_runs, progress=_progress
    )
    print(estimation.format_report(report))
    if args.json:
        estimation.write_json(report, args.json)
        print(f"wrote {args.json}")
    return 0


def _cmd_urban(args: argparse.Namespace) -> int:
    from gcs.bench import urban_report
    from gcs.scenarios import load_scenario
    from gcs.world_loader import build_world

    scenario = load_scenario(args.scenario)
    world = build_world(scenario)
    report, records = urban_report.run_benchmark(
        scenario, world, runs=args.runs, seed=args.seed, planners=args.planner or PLANNERS, duration_s=args.duration,
        motion=args.motion, scaling=() if args.no_scaling else (3, 6, 10, 20), progress=_progress,
    )
    print(urban_report.format_report(report))
    if args.json:
        urban_report.write_json(report, args.json)
        print(f"wrote {args.json}")
    if args.plots:
        for path in urban_report.write_plots(report, records, world, args.plots):
            print(f"wrote {path}")
    return 0


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def add_bench(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs bench`` and its benchmarks."""
    parser = sub.add_parser("bench", help="reproduce the papers' experiments and measure speed",
                            description="Benchmarks: each prints its table and can write --json.")
    benches = parser.add_subparsers(dest="bench", required=True, metavar="BENCHMARK")
    est = benches.add_parser(
        "estimation",
        help="DUIF vs FilterPy's UKF: RMSE, RMSE/sqrt(PCRLB), NEES, microseconds per step",
        description="Feeds the same generated data (wang2012's sensor set-up, vehicles loitering around "
                    "the target) to our DUIF and to FilterPy's UnscentedKalmanFilter with every vehicle "
                    "stacked, and reports accuracy against the PCRLB and speed, plus a table for "
                    "1, 3, 10 and 30 vehicles.",
    )
    est.add_argument("--runs", type=_positive_int, default=100, help="Monte Carlo runs with 3 vehicles (default 100)")
    est.add_argument("--steps", type=_positive_int, default=100, help="1 s steps per run (default 100)")
    est.add_argument("--table-runs", type=_positive_int, default=5, help="runs per row of the vehicle-count table (default 5)")
    est.add_argument("--seed", type=int, default=2012, help="seed of the generated data (default 2012)")
    est.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    est.set_defaults(handler=_cmd_estimation)

    urb = benches.add_parser(
        "urban",
        help="wang2012 section 5 closed loop: observations, RMSE and decision time per planner",
        description="Runs the closed loop (truth target, occluded sensing, DUIF, k+n prediction, planning, "
                    "UAVs flying the first command) on paired seeds for each planner and prints Table 1 "
                    "of wang2012 with RMSE and decision times, plus GA timing for 3, 6, 10 and 20 UAVs.",
    )
    urb.add_argument("--scenario", default="wang2012_urban", help="shipped name or .toml path (default wang2012_urban)")
    urb.add_argument("--runs", type=_positive_int, default=10, help="paired runs per planner (default 10)")
    urb.add_argument("--seed", type=int, default=2012, help="seed of the first run (default 2012)")
    urb.add_argument("--planner", action="append", choices=PLANNERS,
                     help=f"planner to run (repeatable; default all: {', '.join(PLANNERS)})")
    urb.add_argument("--duration", type=float, help="seconds of simulation per run (default: the scenario's)")
    urb.add_argument("--motion", choices=["white_noise_acceleration", "streets"],
                     help="target motion (default: the scenario's)")
    urb.add_argument("--no-scaling", action="store_true", help="skip the 3/6/10/20-UAV GA timing table")
    urb.add_argument("--json", type=Path, metavar="FILE", help="also write the report as JSON")
    urb.add_argument("--plots", type=Path, metavar="DIR", help="write PNG plots into DIR")
    urb.set_defaults(handler=_cmd_urban, planner=None)
