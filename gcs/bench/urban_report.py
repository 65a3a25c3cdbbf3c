"""``gcs bench urban``: paired closed-loop runs, Table 1 / Figs. 6-8 of wang2012, and plots.

Runs every requested planner on the same seeds (paired runs: same city, same
target path, same sensor noise), then reports per planner the mean
observations per UAV and by at least one UAV, the fused position RMSE, and the
decision time (median and 99th percentile). A second table times the GA for
3, 6, 10 and 20 UAVs over a short run.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from gcs.bench.plots import cell, pyplot, write_markdown
from gcs.bench.plots import save as save_figure
from gcs.bench.urban import PLANNERS, RunRecord, run_closed_loop, with_vehicles
from gcs.config import Scenario
from gcs.core.world import World

__all__ = ["run_benchmark", "summarise", "format_report", "write_plots", "write_table"]


def summarise(records: Sequence[RunRecord]) -> dict:
    """Means over runs of one planner; decision times pooled over every step of every run."""
    decisions = np.concatenate([r.decision_s for r in records])
    decisions = decisions[np.isfinite(decisions)] * 1e3
    errors = np.concatenate([r.errors_m for r in records])
    errors = errors[np.isfinite(errors)]
    return {
        "runs": len(records),
        "steps": int(records[0].seen.shape[0]),
        "seen_any_mean": float(np.mean([r.seen_any for r in records])),
        "seen_any_min": int(min(r.seen_any for r in records)),
        "seen_per_uav_mean": [float(x) for x in np.mean([r.seen_per_uav for r in records], axis=0)],
        "rmse_m": float(np.sqrt(np.mean(errors**2))) if errors.size else float("nan"),
        "decision_ms_median": float(np.median(decisions)) if decisions.size else float("nan"),
        "decision_ms_p99": float(np.percentile(decisions, 99)) if decisions.size else float("nan"),
    }


def run_benchmark(
    scenario: Scenario,
    world: World,
    runs: int,
    seed: int,
    planners: Sequence[str] = PLANNERS,
    duration_s: float | None = None,
    motion: str | None = None,
    scaling: Sequence[int] = (3, 6, 10, 20),
    scaling_duration_s: float = 20.0,
    progress: Callable[[str], None] | None = None,
) -> tuple[dict, dict[str, list[RunRecord]]]:
    """Paired runs of every planner, and the GA timing table; returns (report, records).

    ``world`` is the scenario's (:func:`gcs.world_loader.build_world`); the timing
    table reuses it, since adding UAVs does not change the city.
    """
    say = progress or (lambda _msg: None)
    records: dict[str, list[RunRecord]] = {name: [] for name in planners}
    for run in range(runs):
        for name in planners:
            record = run_closed_loop(scenario, world, name, seed + run, duration_s=duration_s, motion=motion)
            records[name].append(record)
            say(f"run {run + 1}/{runs} {name}: seen by any {record.seen_any}/{record.seen.shape[0]}, "
                f"per UAV {record.seen_per_uav}, RMSE {record.rmse_m:.1f} m")
    table = []
    for count in scaling:  # the full GA budget, no early stop: the paper's 50 x 200
        bigger = with_vehicles(scenario, count)
        record = run_closed_loop(bigger, world, "ga_k5", seed, duration_s=scaling_duration_s,
                                 motion=motion, stall=None)
        row = summarise([record])
        table.append({"uavs": count, "decision_ms_median": row["decision_ms_median"],
                      "decision_ms_p99": row["decision_ms_p99"], "seen_any": record.seen_any,
                      "steps": row["steps"]})
        say(f"GA timing with {count} UAVs: median {row['decision_ms_median']:.1f} ms")
    report = {
        "scenario": scenario.name, "runs": runs, "seed": seed,
        "motion": motion or scenario.target.motion,
        "ga": {"population": scenario.planner.population, "generations": scenario.planner.generations,
               "stall_generations": scenario.planner.stall_generations},
        "planners": {name: summarise(recs) for name, recs in records.items()},
        "scaling": table,
    }
    return report, records


def format_report(report: dict) -> str:
    """Table 1 style text."""
    lines = [
        f"urban benchmark: {report['scenario']}, {report['runs']} paired runs from seed {report['seed']}, "
        f"target motion {report['motion']}, GA {report['ga']['population']} x {report['ga']['generations']}"
        + (f" (stop after {report['ga']['stall_generations']} without improvement)" if report['ga']['stall_generations'] else ""),
        f"{'planner':<9}{'seen by any':>13}{'(min)':>7}{'seen per UAV':>26}{'RMSE m':>9}{'decision ms':>13}{'p99':>8}",
    ]
    for name, p in report["planners"].items():
        per_uav = "/".join(f"{x:.0f}" for x in p["seen_per_uav_mean"])
        lines.append(f"{name:<9}{p['seen_any_mean']:>9.1f}/{p['steps']:<3}{p['seen_any_min']:>7}{per_uav:>26}"
                     f"{p['rmse_m']:>9.2f}{p['decision_ms_median']:>13.1f}{p['decision_ms_p99']:>8.1f}")
    if report["scaling"]:
        ga = report["ga"]
        lines += ["", f"GA {ga['population']} x {ga['generations']}, every generation run:",
                  f"{'UAVs':>5}{'GA decision ms (median)':>25}{'p99':>8}{'seen by any':>14}"]
    for row in report["scaling"]:
        lines.append(f"{row['uavs']:>5}{row['decision_ms_median']:>25.1f}{row['decision_ms_p99']:>8.1f}"
                     f"{row['seen_any']:>9}/{row['steps']}")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """JSON with ``planners.<name>.{seen_any_mean, seen_per_uav_mean, rmse_m, decision_ms_median, decision_ms_p99}``."""
    path.write_text(json.dumps(report, indent=2) + "\n")


def write_table(report: dict, directory: Path, written: list[Path] | None = None) -> Path:
    """``urban.md``: Table 1 (observations, RMSE, decision time per planner) and the GA timing table."""
    planners = [(name, p["runs"], p["steps"], p["seen_any_mean"], p["seen_any_min"],
                 " / ".join(cell(x, 3) for x in p["seen_per_uav_mean"]), p["rmse_m"], p["decision_ms_median"],
                 p["decision_ms_p99"]) for name, p in report["planners"].items()]
    scaling = [(row["uavs"], row["decision_ms_median"], row["decision_ms_p99"], row["seen_any"], row["steps"])
               for row in report["scaling"]]
    sections = [("Observations and accuracy (wang2012 Table 1)",
                 ["planner", "runs", "steps", "seen by any (mean)", "seen by any (min)", "seen per UAV (mean)",
                  "RMSE m", "decision ms (median)", "decision ms (p99)"], planners)]
    if scaling:
        sections.append(("GA decision time by team size", ["UAVs", "decision ms (median)", "decision ms (p99)",
                                                           "seen by any", "steps"], scaling))
    return write_markdown(directory, "urban.md", f"gcs bench urban: {report['scenario']}", sections,
                          [f"{report['runs']} paired runs from seed {report['seed']}, target motion {report['motion']}, "
                           f"GA {report['ga']['population']} x {report['ga']['generations']}"], written)


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
