"""``gcs-bench urban``: paired closed-loop runs per planner, significance against the orbit, a timing table, plots.

Runs every requested planner on the same seeds (paired runs: same city, same
target path, same sensor noise), then reports per planner the mean steps at
which at least one UAV saw the target, the mean per UAV, the fused position
RMSE, the runs that lost the track (:data:`benchmarks.urban.LOST_M`), the
vehicle-steps inside restricted airspace, and the decision time (median and
99th percentile of every plan job: tables or maps, search and the airspace
guard). Beside the means, the paired Wilcoxon signed-rank test (two-sided) of
seen-by-any against the orbit, and of each k+n planner against its k+0 twin
(``sight`` / ``sight_k0``, ``ga_k5`` / ``ga_k0``).

A second table says how the track is lost (:mod:`benchmarks.lost_track`): the error's
p95 and maximum, the runs and steps with the error over 50 m and over 100 m, the
longest stretch no UAV saw the target (the worst run's, and the median run's), and
the share of steps whose position NEES lies inside its 95% band. The point scored
(:data:`SCORED`) is the position of the ``TrackEstimate`` the engine publishes for each
decision step.

A second table times the default planner and the paper's GA for 3, 6, 10 and 20
UAVs over a short run, in this process after the paired runs, the two alternated step by
step, each with its median and interquartile range, and the GA's time over the default's
step by step (:mod:`benchmarks.urban_timing`).
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from benchmarks.lost_track import error_figures, longest_unseen, nees_inside
from benchmarks.plots import cell, pyplot, write_markdown
from benchmarks.plots import save as save_figure
from benchmarks.urban import PLANNERS, RunRecord
from benchmarks.urban_runs import RunJob, run_jobs, with_estimator
from benchmarks.urban_timing import SCALING_PLANNERS, iqr_text, scaling_lines, scaling_table
from gcs.config import Scenario, estimator_kind
from gcs.core.world import World

__all__ = ["K0_TWIN", "SCALING_PLANNERS", "SCORED", "paired_p", "run_benchmark", "summarise", "format_report",
           "write_json", "write_plots", "write_table"]

SCORED = ("the position of the TrackEstimate the engine publishes for each decision step (the tracker's posterior "
          "mean at the step's stamp)")
"""The point estimate the errors, RMSE and NEES score, as the report says it."""

K0_TWIN = {"sight": "sight_k0", "ga_k5": "ga_k0"}
"""Each k+n planner and the same planner on the current estimate."""


def paired_p(a: Sequence[float], b: Sequence[float]) -> float:
    """Two-sided paired Wilcoxon signed-rank p of a against b (1.0 when every pair is equal)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if len(x) != len(y):
        raise ValueError("paired samples must have the same length")
    if not np.any(x != y):
        return 1.0
    return float(wilcoxon(x, y).pvalue)


def summarise(records: Sequence[RunRecord]) -> dict:
    """Means over runs of one planner; decision times pooled over every step of every run."""
    decisions = np.concatenate([r.decision_s for r in records])
    decisions = decisions[np.isfinite(decisions)] * 1e3
    errors = np.concatenate([r.errors_m for r in records])
    errors = errors[np.isfinite(errors)]
    nees = np.concatenate([r.nees[np.isfinite(r.nees)] for r in records if r.nees is not None] or [np.zeros(0)])
    unseen = [longest_unseen(r.seen.any(axis=1)) for r in records]
    return {
        "runs": len(records),
        "steps": int(records[0].seen.shape[0]),
        "seeds": [r.seed for r in records],
        "seen_any": [r.seen_any for r in records],
        "seen_any_mean": float(np.mean([r.seen_any for r in records])),
        "seen_any_min": int(min(r.seen_any for r in records)),
        "seen_per_uav_mean": [float(x) for x in np.mean([r.seen_per_uav for r in records], axis=0)],
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else float("nan"),
        "rmse_m_per_run": [r.rmse_m for r in records],
        "max_error_per_run_m": [float(np.nanmax(r.errors_m)) if np.isfinite(r.errors_m).any() else float("nan")
                                for r in records],
        "lost_runs": int(sum(r.lost for r in records)),
        "engine_counters": dict(sum((Counter(r.counters or {}) for r in records), Counter())),
        "lost_track": {**error_figures([r.errors_m for r in records]),
                       "nees_in_band": float(nees_inside(nees).mean()) if nees.size else float("nan"),
                       "longest_unseen_max": int(max(unseen)), "longest_unseen_median": float(np.median(unseen)),
                       "longest_unseen": unseen},
        "violations": int(sum(r.violation_steps for r in records)),
        "decision_ms_median": float(np.median(decisions)) if decisions.size else float("nan"),
        "decision_ms_p99": float(np.percentile(decisions, 99)) if decisions.size else float("nan"),
    }


def _compare(planners: dict[str, dict]) -> None:
    """Add ``p_vs_orbit`` (and ``p_vs_k0``, ``k0``) to every planner's summary, paired by seed."""
    orbit = planners.get("orbit")
    for name, summary in planners.items():
        if orbit is not None and name != "orbit":
            summary["p_vs_orbit"] = paired_p(summary["seen_any"], orbit["seen_any"])
            summary["gain_vs_orbit"] = summary["seen_any_mean"] - orbit["seen_any_mean"]
        twin = planners.get(K0_TWIN.get(name, ""))
        if twin is not None:
            summary["k0"] = K0_TWIN[name]
            summary["p_vs_k0"] = paired_p(summary["seen_any"], twin["seen_any"])
            summary["gain_vs_k0"] = summary["seen_any_mean"] - twin["seen_any_mean"]


def run_benchmark(
    scenario_name: str,
    scenario: Scenario,
    world: World,
    runs: int,
    seed: int,
    planners: Sequence[str] = PLANNERS,
    duration_s: float | None = None,
    motion: str | None = None,
    scaling: Sequence[int] = (3, 6, 10, 20),
    scaling_duration_s: float = 20.0,
    workers: int = 1,
    dask: str | None = None,
    progress: Callable[[str], None] | None = None,
    estimator: str | None = None,
) -> tuple[dict, dict[str, list[RunRecord]]]:
    """Paired runs of every planner, and the timing table; returns (report, records).

    ``scenario_name`` is what the runs load (a shipped name or a .toml path; the
    workers load it themselves), ``scenario`` and ``world`` its contents, for the
    timing table, which adds UAVs to the scenario and runs here. ``estimator`` replaces the
    scenario's ``[estimator] kind`` in every run (None: the scenario's).
    """
    say = progress or (lambda _msg: None)
    if estimator is not None:
        scenario = with_estimator(scenario, estimator)
    jobs = [RunJob(scenario_name, name, seed + run, duration_s, motion, estimator=estimator)
            for run in range(runs) for name in planners]

    def done(job: RunJob, record: RunRecord) -> None:
        say(f"seed {job.seed} {job.planner}: seen by any {record.seen_any}/{record.seen.shape[0]}, "
            f"per UAV {record.seen_per_uav}, RMSE {record.rmse_m:.1f} m"
            + (f", {record.violation_steps} airspace violations" if record.violation_steps else ""))

    all_records = run_jobs(jobs, workers=workers, dask=dask, done=done)
    records: dict[str, list[RunRecord]] = {name: [r for j, r in zip(jobs, all_records) if j.planner == name]
                                           for name in planners}
    table = scaling_table(scenario, world, scaling, seed, scaling_duration_s, motion, say)
    summaries = {name: summarise(recs) for name, recs in records.items()}
    _compare(summaries)
    report = {
        "scenario": scenario.name, "runs": runs, "seed": seed,
        "motion": motion or scenario.target.motion, "estimator": estimator_kind(scenario), "scored": SCORED,
        "ga": {"population": scenario.planner.population, "generations": scenario.planner.generations,
               "stall_generations": scenario.planner.stall_generations,
               "horizon_steps": scenario.planner.horizon_steps},
        "sight": {"horizon_steps": scenario.planner.sight.horizon_steps, "samples": scenario.planner.sight.samples},
        "planners": summaries,
        "scaling": table,
    }
    return report, records


def _p(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.1e}" if value < 1e-3 else f"{value:.3f}"


def format_report(report: dict) -> str:
    """Table 1 style text, with the paired tests and the timing table."""
    ga, sight = report["ga"], report["sight"]
    lines = [
        f"urban benchmark: {report['scenario']}, {report['runs']} paired runs from seed {report['seed']}, "
        f"target motion {report['motion']}, estimator {report.get('estimator', 'duif')}; sight planner horizon {sight['horizon_steps']} steps, "
        f"{sight['samples']} samples; GA {ga['population']} x {ga['generations']}, horizon {ga['horizon_steps']}",
        f"{'planner':<10}{'seen by any':>13}{'(min)':>7}{'seen per UAV':>22}{'RMSE m':>9}{'lost':>6}{'viol.':>7}"
        f"{'ms':>8}{'p99':>8}{'vs orbit':>10}{'p':>9}{'vs k+0':>8}{'p':>9}",
    ]
    for name, p in report["planners"].items():
        per_uav = "/".join(f"{x:.0f}" for x in p["seen_per_uav_mean"])
        orbit = f"{p['gain_vs_orbit']:+.1f}" if "gain_vs_orbit" in p else "-"
        k0 = f"{p['gain_vs_k0']:+.1f}" if "gain_vs_k0" in p else "-"
        lines.append(f"{name:<10}{p['seen_any_mean']:>9.1f}/{p['steps']:<3}{p['seen_any_min']:>7}{per_uav:>22}"
                     f"{p['rmse_m']:>9.2f}{p['lost_runs']:>6}{p['violations']:>7}{p['decision_ms_median']:>8.1f}"
                     f"{p['decision_ms_p99']:>8.1f}{orbit:>10}{_p(p.get('p_vs_orbit')):>9}{k0:>8}"
                     f"{_p(p.get('p_vs_k0')):>9}")
    lines += ["", f"lost track (scored: {report.get('scored', SCORED)}):",
              f"{'planner':<10}{'p95 m':>8}{'max m':>8}{'runs >50':>10}{'>100':>6}{'steps >50':>11}{'>100':>6}"
              f"{'unseen max':>12}{'median':>8}{'NEES in 95%':>13}"]
    for name, p in report["planners"].items():
        t = p["lost_track"]
        lines.append(f"{name:<10}{t['p95_m']:>8.1f}{t['max_m']:>8.1f}{t['runs_over_50']:>10}{t['runs_over_100']:>6}"
                     f"{t['steps_over_50']:>11}{t['steps_over_100']:>6}{t['longest_unseen_max']:>12}"
                     f"{t['longest_unseen_median']:>8.1f}{t['nees_in_band']:>13.3f}")
    lines += scaling_lines(report["scaling"])
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """JSON with ``planners.<name>.{seen_any_mean, seen_per_uav_mean, rmse_m, lost_runs, violations,
    decision_ms_median, decision_ms_p99, p_vs_orbit, p_vs_k0, lost_track.{p95_m, max_m, runs_over_50, runs_over_100,
    steps_over_50, steps_over_100, longest_unseen_max, longest_unseen_median, nees_in_band}}``, ``scored`` (the point
    estimate scored) and the timing table ``scaling``."""
    path.write_text(json.dumps(report, indent=2) + "\n")


def write_table(report: dict, directory: Path, written: list[Path] | None = None) -> Path:
    """``urban.md``: observations, RMSE, lost runs, violations, decision time and tests per planner; timing."""
    planners = [(name, p["runs"], p["seen_any_mean"], p["seen_any_min"],
                 " / ".join(cell(x) for x in p["seen_per_uav_mean"]), p["rmse_m"], p["lost_runs"], p["violations"],
                 p["decision_ms_median"], p["decision_ms_p99"], p.get("p_vs_orbit"), p.get("p_vs_k0"))
                for name, p in report["planners"].items()]
    scaling = [(row["uavs"], *(value for name in SCALING_PLANNERS for value in (
                    row[name]["decision_ms_median"], iqr_text(row[name], "decision_ms"), row[name]["decision_ms_p99"])),
                row["ga_over_sight"], iqr_text(row, "ga_over_sight")) for row in report["scaling"]]
    lost = [(name, p["lost_track"]["p95_m"], p["lost_track"]["max_m"], p["lost_track"]["runs_over_50"],
             p["lost_track"]["runs_over_100"], p["lost_track"]["steps_over_50"], p["lost_track"]["steps_over_100"],
             p["lost_track"]["longest_unseen_max"], p["lost_track"]["longest_unseen_median"],
             p["lost_track"]["nees_in_band"]) for name, p in report["planners"].items()]
    sections = [("Observations and accuracy",
                 ["planner", "runs", "seen by any (mean)", "seen by any (min)", "seen per UAV (mean)", "RMSE m",
                  "runs lost", "airspace violations", "decision ms (median)", "decision ms (p99)", "p vs orbit",
                  "p vs k+0"], planners),
                ("Lost track", ["planner", "error p95 m", "error max m", "runs over 50 m", "runs over 100 m",
                                "steps over 50 m", "steps over 100 m", "longest unseen (max)",
                                "longest unseen (median)", "NEES in 95% band"], lost)]
    if scaling:
        sections.append(("Decision time by team size (the planners alternated step by step)",
                         ["UAVs", "sight ms (median)", "sight ms (IQR)", "sight ms (p99)", "GA ms (median)",
                          "GA ms (IQR)", "GA ms (p99)", "GA / sight (median)", "GA / sight (IQR)"], scaling))
    return write_markdown(directory, "urban.md", f"gcs-bench urban: {report['scenario']}", sections,
                          [f"{report['runs']} paired runs from seed {report['seed']}, target motion {report['motion']}",
                           f"scored: {report.get('scored', SCORED)}"], written)


def write_plots(report: dict, records: dict[str, list[RunRecord]], world: World, directory: Path) -> list[Path]:
    """PNG plots: city with trajectories (Fig. 4), RMSE over time (Figs. 6, 8), observations (Fig. 7); and the
    tables (``urban.md``)."""
    from matplotlib.patches import Polygon

    plt = pyplot()
    written: list[Path] = []

    def save(fig, name: str) -> None:
        save_figure(fig, directory, name, written)

    first = next(iter(records.values()))[0]
    fig, ax = plt.subplots(figsize=(8, 8))
    for footprint in world.buildings.footprints:
        ax.add_patch(Polygon(footprint, closed=True, facecolor="0.8", edgecolor="0.5", linewidth=0.3))
    for zone in world.airspace.polygons:
        ax.add_patch(Polygon(zone, closed=True, facecolor=(1.0, 0.0, 0.0, 0.12), edgecolor="red", linewidth=0.8))
    for i in range(first.vehicle_xy.shape[1]):
        ax.plot(first.vehicle_xy[:, i, 0], first.vehicle_xy[:, i, 1], linewidth=0.8, label=f"UAV {i + 1}")
    ax.plot(first.target_xy[:, 0], first.target_xy[:, 1], "k-", linewidth=1.5, label="target (truth)")
    ax.plot(first.estimate_xy[:, 0], first.estimate_xy[:, 1], "r--", linewidth=0.8, label="target (fused estimate)")
    ax.set_xlim(0, world.size_m[0])
    ax.set_ylim(0, world.size_m[1])
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"{first.planner}, seed {first.seed}: trajectories")
    ax.legend(loc="upper right", fontsize=8)
    save(fig, "urban_trajectories.png")

    fig, ax = plt.subplots(figsize=(9, 4))
    for name, recs in records.items():
        errors = np.stack([r.errors_m for r in recs])
        curve = np.sqrt(np.nanmean(errors**2, axis=0))
        ax.plot(np.arange(curve.size), curve, label=f"{name} (RMSE {report['planners'][name]['rmse_m']:.1f} m)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("fused position RMSE over runs (m)")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
    ax.set_title("Fused target position error (wang2012 Figs. 6 and 8)")
    save(fig, "urban_rmse.png")

    fig, ax = plt.subplots(figsize=(9, 4))
    names = list(report["planners"])
    uavs = len(report["planners"][names[0]]["seen_per_uav_mean"])
    width = 0.8 / (uavs + 1)
    for j in range(uavs + 1):
        values = [report["planners"][n]["seen_per_uav_mean"][j] if j < uavs else report["planners"][n]["seen_any_mean"]
                  for n in names]
        ax.bar(np.arange(len(names)) + j * width, values, width, label=f"UAV {j + 1}" if j < uavs else "at least one")
    ax.set_xticks(np.arange(len(names)) + 0.4 - width / 2, names)
    ax.set_ylabel("steps with the target observed (mean over runs)")
    ax.legend(fontsize=8)
    ax.set_title("Observations (wang2012 Table 1, Fig. 7)")
    save(fig, "urban_observations.png")
    write_table(report, directory, written)
    return written
