"""``gcs-bench demo``: ``gcs demo`` at its default settings against the in-process loop, seed by seed.

For each seed the same scenario is flown twice:

* **demo**: what ``gcs demo --seed S`` runs, the daemon in this process (its planner in
  a child process) and ``sim-vehicles run --seed S`` in another, on loopback at the
  demo's rate, with Zenoh reports and MAVLink commands;
* **in process**: :func:`benchmarks.autopilots.fly`, the same scene (truth, target,
  sensors: the same seed's random streams), the same autopilot personality and the
  daemon's own steering and MAVLink encoding, in one process with no network and no
  clock: every plan is made at once and flown from the step it was made for.

The report gives, per mode, the means over the seeds of seen-by-any and of each UAV,
the RMSE pooled over the runs' scored steps (root of the mean of the runs' mean squares; with
``[multitarget]`` the GOSPA mean instead: the steps' GOSPA against every target, averaged over the
runs' scored steps, the figure ``gcs demo`` and ``gcs-bench multitarget`` give under that name), the demo's ratios to the in-process loop, and the paired (seed by seed)
Wilcoxon signed-rank p of each figure. The issue's bars: seen-by-any
within 2%, each UAV within 5%, RMSE within 15%. Per seed the two runs are not the same
trajectory (the live loop's timing differs, and a different plan soon gives a
different flight), so only the means over seeds compare.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from gcs.daemon import demo
from benchmarks.autopilots import fly
from benchmarks.urban_report import paired_p
from gcs.cli import build_parser
from gcs.config.world import build_world
from gcs.engine.records import step_error_m
from gcs.scenarios import load_scenario

__all__ = ["run_benchmark", "format_report", "write_json"]


def _demo_run(scenario: str, seed: int, rate: float, duration_s: float | None, wait_for_plans: bool) -> dict:
    """One ``gcs demo --scenario SCENARIO --seed SEED --rate RATE``; its summary (seen_any, seen_per_uav, rmse_m,
    ...; ``rmse_m`` with many targets the GOSPA mean: :func:`_error_m`)."""
    argv = ["demo", "--scenario", scenario, "--seed", str(seed), "--rate", str(rate)] + (
        [] if duration_s is None else ["--duration", str(duration_s)])
    args = build_parser().parse_args(argv)
    daemon = demo.check_demo(args)
    daemon.open()
    duration = duration_s if duration_s is not None else daemon.scenario.time.duration_s
    command = demo.simulator_command(daemon, args.scenario, rate, duration, seed,
                                     ("--wait-for-plans",) if wait_for_plans else ())
    if demo.run_together(daemon, command):
        raise KeyboardInterrupt  # Ctrl-C stops the benchmark, not this run alone
    summary = demo.summarise(daemon.records, daemon.plans, daemon.roster)
    errors = np.array([step_error_m(r) for r in daemon.records if step_error_m(r) is not None])
    return {"seen_any": summary["seen_any"], "seen_per_uav": list(summary["seen_per_uav"].values()),
            "rmse_m": _error_m(errors, daemon.scenario.multitarget is not None), "steps": summary["steps"],
            "scenario": daemon.scenario.name}


def _in_process_run(scenario, world, seed: int, duration_s: float | None) -> dict:
    personality = scenario.autopilot_for(scenario.vehicles[0])
    record = fly(scenario, world, personality, seed, duration_s=duration_s)
    errors = record.errors_m[np.isfinite(record.errors_m)]
    return {"seen_any": record.seen_any, "seen_per_uav": record.seen_per_uav,
            "rmse_m": _error_m(errors, scenario.multitarget is not None), "steps": int(record.seen.shape[0])}


def _error_m(errors: np.ndarray, many_targets: bool) -> float | None:
    """A run's track error over its scored steps: the RMSE, or with many targets the GOSPA mean."""
    if not errors.size:
        return None
    return float(np.mean(errors)) if many_targets else float(np.sqrt(np.mean(errors**2)))


def _means(runs: list[dict], many_targets: bool) -> dict:
    """The means over the runs; the track error pooled as the runs' figures are (:func:`_error_m`)."""
    errors = [r["rmse_m"] for r in runs if r["rmse_m"] is not None]
    pooled = float(np.mean(errors)) if many_targets else float(np.sqrt(np.mean(np.square(errors))))
    return {"seen_any_mean": float(np.mean([r["seen_any"] for r in runs])),
            "seen_per_uav_mean": [float(x) for x in np.mean([r["seen_per_uav"] for r in runs], axis=0)],
            "rmse_m": pooled if errors else None, "seen_any": [r["seen_any"] for r in runs]}


def run_benchmark(scenario_name: str, runs: int, seed: int, rate: float | None = None,
                  duration_s: float | None = None, wait_for_plans: bool = False,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Both modes on seeds ``seed .. seed + runs - 1``; the report (module docstring).

    ``rate`` defaults to :data:`gcs.daemon.demo.DEFAULT_RATE`, the demo's own."""
    rate = demo.DEFAULT_RATE if rate is None else rate
    say = progress or (lambda _message: None)
    scenario = load_scenario(scenario_name)
    world = build_world(scenario)
    demo_runs, loop_runs = [], []
    for s in range(seed, seed + runs):
        loop_runs.append(_in_process_run(scenario, world, s, duration_s))
        demo_runs.append(_demo_run(scenario_name, s, rate, duration_s, wait_for_plans))
        say(f"seed {s}: demo seen by any {demo_runs[-1]['seen_any']}, per UAV {demo_runs[-1]['seen_per_uav']}; "
            f"in process {loop_runs[-1]['seen_any']}, per UAV {loop_runs[-1]['seen_per_uav']}")
    many = scenario.multitarget is not None
    demo_means, loop_means = _means(demo_runs, many), _means(loop_runs, many)
    ratios = {"seen_any": demo_means["seen_any_mean"] / loop_means["seen_any_mean"],
              "seen_per_uav": [d / max(p, 1e-9) for d, p in zip(demo_means["seen_per_uav_mean"],
                                                               loop_means["seen_per_uav_mean"])],
              "rmse": (demo_means["rmse_m"] / loop_means["rmse_m"]
                       if demo_means["rmse_m"] and loop_means["rmse_m"] else None)}
    return {"scenario": scenario.name, "many_targets": scenario.multitarget is not None, "runs": runs, "seed": seed,
            "rate": rate, "wait_for_plans": wait_for_plans,
            "duration_s": duration_s or scenario.time.duration_s, "demo": demo_means, "in_process": loop_means,
            "ratios": ratios, "paired_p": _paired_p(demo_runs, loop_runs),
            "per_seed": {"demo": demo_runs, "in_process": loop_runs}}


def _paired_p(demo_runs: list[dict], loop_runs: list[dict]) -> dict:
    """Paired Wilcoxon p of the demo against the in-process loop, seed by seed: seen-by-any, each UAV and RMSE
    (RMSE over the seeds where both scored a step)."""
    def p(key: str, pick=lambda value: value) -> float:
        pairs = [(pick(d[key]), pick(l[key])) for d, l in zip(demo_runs, loop_runs)
                 if pick(d[key]) is not None and pick(l[key]) is not None]
        return paired_p([a for a, _ in pairs], [b for _, b in pairs]) if len(pairs) >= 2 else float("nan")

    uavs = len(demo_runs[0]["seen_per_uav"]) if demo_runs else 0
    return {"seen_any": p("seen_any"), "seen_per_uav": [p("seen_per_uav", lambda v, i=i: v[i]) for i in range(uavs)],
            "rmse": p("rmse_m")}


def format_report(report: dict) -> str:
    """The report as a markdown table."""
    def row(name: str, means: dict) -> str:
        per_uav = " / ".join(f"{x:.1f}" for x in means["seen_per_uav_mean"])
        rmse = "-" if means["rmse_m"] is None else f"{means['rmse_m']:.2f}"
        return f"| {name} | {means['seen_any_mean']:.1f} | {per_uav} | {rmse} | {means['seen_any']} |"

    ratios, paired = report["ratios"], report["paired_p"]
    per_uav = " / ".join(f"{x:.3f}" for x in ratios["seen_per_uav"])
    rmse = "-" if ratios["rmse"] is None else f"{ratios['rmse']:.3f}"
    per_uav_p = " / ".join(f"{x:.2g}" for x in paired["seen_per_uav"])
    return "\n".join([
        f"gcs-bench demo: {report['scenario']}, seeds {report['seed']}-{report['seed'] + report['runs'] - 1}, "
        f"{report['duration_s']:.0f} s at {report['rate']:g}x" + (", vehicles waiting for plans"
                                                                 if report["wait_for_plans"] else ""), "",
        f"| loop | seen by any (mean) | per UAV (mean) | {'GOSPA mean' if report.get('many_targets') else 'RMSE'} (m) "
        "| seen by any per seed |",
        "|---|---|---|---|---|",
        row("gcs demo", report["demo"]), row("in process", report["in_process"]),
        f"| demo / in process | {ratios['seen_any']:.3f} | {per_uav} | {rmse} | |",
        f"| paired Wilcoxon p | {paired['seen_any']:.2g} | {per_uav_p} | {paired['rmse']:.2g} | |"])


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")
