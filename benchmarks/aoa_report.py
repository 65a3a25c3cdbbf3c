"""``gcs-bench aoa``: the zuo2021 experiments (Figs. 2-8) over paired runs, their tables, JSON and plots.

Every run index ``r`` uses the seed ``seed + r`` for every configuration (the same
measurement noise draws), so the comparisons are paired:

* estimators (Fig. 2): ML-VUKF, ML-EKF, LS-EKF and the GCRLB, straight flight;
* planners (Figs. 3-6): GCRLB-LM, Dogancay's CRLB-LM and straight-line flight, 3 UAVs;
* sensor count (Fig. 7): GCRLB-LM with 2-6 UAVs (``sigma_0`` = 1 deg);
* unequal accuracies (Fig. 8): GCRLB-LM with ``sigma_0`` = 1 / 0.8 / 0.1 deg.

MSE is the mean over runs of the squared position error at a step; ``final_mse``
is at the last step. Means of squared errors are dominated by the worst runs, so
the median is reported beside them, and the planners' pairing is tested with the
Wilcoxon signed-rank test on the runs' final squared errors.

The three planners of Figs. 3-6 fly each seed alternated step by step in this process
(:func:`benchmarks.aoa_loop.run_alternated`), so a change in the machine's load lands on
all three; each planner's plan time per step is given as its median, interquartile range
and 99th percentile, and GCRLB-LM's over CRLB-LM's step by step as a median and IQR.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from scipy.stats import wilcoxon

from benchmarks.aoa import ESTIMATORS, PLANNERS, AoaScenario, LoopRecord, run_estimators
from benchmarks.aoa_loop import run_alternated, run_loop
from benchmarks.plots import pyplot, write_markdown
from benchmarks.plots import save as save_figure

__all__ = ["SENSOR_COUNTS", "UNEQUAL_SIGMA0_DEG", "run_benchmark", "format_report", "write_json", "write_plots",
           "write_table"]

SENSOR_COUNTS = (2, 3, 4, 5, 6)
UNEQUAL_SIGMA0_DEG = (1.0, 0.8, 0.1)
LM_STEP_GOAL_MS = 20.0


def _curve(values: np.ndarray) -> list[float]:
    return [float(x) for x in values]


def _loop_summary(records: Sequence[LoopRecord]) -> dict:
    """Accuracy, bound, violations and solve time of one configuration's runs."""
    se = np.stack([r.squared_error for r in records])
    bound = np.stack([r.bound for r in records])
    solve_ms = np.concatenate([r.solve_s for r in records]) * 1e3
    solve_ms = solve_ms[np.isfinite(solve_ms)]
    kinds = {kind: sum(r.violations[kind] for r in records) for kind in records[0].violations}
    return {
        "runs": len(records),
        "final_mse": float(se[:, -1].mean()),
        "final_se_median": float(np.median(se[:, -1])),
        "mean_mse": float(se.mean()),
        "final_bound": float(bound[:, -1].mean()),
        "violations": int(sum(kinds.values())),
        "violations_by_kind": kinds,
        "step_ms_median": float(np.median(solve_ms)) if solve_ms.size else float("nan"),
        "step_ms_p25": float(np.percentile(solve_ms, 25)) if solve_ms.size else float("nan"),
        "step_ms_p75": float(np.percentile(solve_ms, 75)) if solve_ms.size else float("nan"),
        "step_ms_p99": float(np.percentile(solve_ms, 99)) if solve_ms.size else float("nan"),
        "iterations_median": float(np.median(np.concatenate([r.iterations for r in records]))),
        "mse_curve": _curve(se.mean(axis=0)),
        "median_curve": _curve(np.median(se, axis=0)),
        "bound_curve": _curve(bound.mean(axis=0)),
    }


def _step_ratio(a: Sequence[LoopRecord], b: Sequence[LoopRecord]) -> dict[str, float]:
    """``a``'s plan time over ``b``'s, step by step on the same seeds (the planners alternated): median and IQR."""
    ratio = np.concatenate([ra.solve_s / rb.solve_s for ra, rb in zip(a, b)])
    ratio = ratio[np.isfinite(ratio)]
    if not ratio.size:
        return {"median": float("nan"), "p25": float("nan"), "p75": float("nan")}
    p25, median, p75 = np.percentile(ratio, [25.0, 50.0, 75.0])
    return {"median": float(median), "p25": float(p25), "p75": float(p75)}


def _paired(a: Sequence[LoopRecord], b: Sequence[LoopRecord]) -> dict:
    """How often ``a`` ends with the smaller squared error than ``b`` on the same seed, and Wilcoxon's p."""
    ea, eb = np.array([r.squared_error[-1] for r in a]), np.array([r.squared_error[-1] for r in b])
    p = float(wilcoxon(ea, eb).pvalue) if len(ea) > 1 and np.any(ea != eb) else float("nan")
    return {"wins": int((ea < eb).sum()), "runs": len(ea), "wilcoxon_p": p}


def run_benchmark(
    runs: int,
    seed: int,
    steps: int = 100,
    progress: Callable[[str], None] | None = None,
    clock: Callable[[], float] | None = time.perf_counter,
) -> tuple[dict, dict]:
    """Every experiment, ``runs`` paired runs each; returns (report, records for the plots)."""
    say = progress or (lambda _msg: None)
    scenario = AoaScenario(steps=steps)
    estimates: list[dict[str, np.ndarray]] = []
    planners: dict[str, list[LoopRecord]] = {name: [] for name in PLANNERS}
    counts: dict[int, list[LoopRecord]] = {n: [] for n in SENSOR_COUNTS}
    counts[3] = planners["gcrlb_lm"]
    unequal: list[LoopRecord] = []
    for run in range(runs):
        run_seed = seed + run
        estimates.append(run_estimators(scenario, run_seed))
        for name, record in run_alternated(scenario, PLANNERS, run_seed, clock=clock).items():
            planners[name].append(record)
        for n in SENSOR_COUNTS:
            if n != 3:
                counts[n].append(run_loop(scenario, "gcrlb_lm", run_seed, (1.0,) * n, clock=clock))
        unequal.append(run_loop(scenario, "gcrlb_lm", run_seed, UNEQUAL_SIGMA0_DEG, clock=clock))
        finals = ", ".join(f"{name} {recs[-1].squared_error[-1]:.3g}" for name, recs in planners.items())
        say(f"run {run + 1}/{runs} (seed {run_seed}): final squared error m^2: {finals}")
    estimators = {}
    for name in ESTIMATORS:
        se = np.stack([e[name] for e in estimates])
        estimators[name] = {"final_mse": float(se[:, -1].mean()), "final_se_median": float(np.median(se[:, -1])),
                            "mean_mse": float(se.mean()), "mse_curve": _curve(se.mean(axis=0)),
                            "median_curve": _curve(np.median(se, axis=0))}
    bound = estimates[0]["gcrlb"]  # the same trajectories and truth in every run
    estimators["gcrlb"] = {"final_mse": float(bound[-1]), "final_se_median": float(bound[-1]),
                           "mean_mse": float(bound.mean()), "mse_curve": _curve(bound)}
    summary = {name: _loop_summary(recs) for name, recs in planners.items()}
    lm_runs = [*planners["gcrlb_lm"], *planners["crlb_lm"], *unequal, *(r for n in SENSOR_COUNTS if n != 3 for r in counts[n])]
    report = {
        "scenario": {"target_start_m": scenario.target_start_m, "target_velocity_mps": scenario.target_velocity_mps,
                     "uav_starts_m": scenario.uav_starts_m, "speed_mps": scenario.speed_mps,
                     "step_s": scenario.step_s, "max_turn_deg": scenario.max_turn_deg,
                     "reference_range_m": scenario.reference_range_m, "detection_range_m": scenario.detection_range_m,
                     "separation_m": scenario.separation_m, "steps": steps},
        "runs": runs, "seed": seed,
        "estimators": estimators,
        "planners": summary,
        "paired": {"gcrlb_lm_vs_crlb_lm": _paired(planners["gcrlb_lm"], planners["crlb_lm"]),
                   "crlb_lm_vs_straight_line": _paired(planners["crlb_lm"], planners["straight_line"])},
        "step_time_gcrlb_lm_over_crlb_lm": _step_ratio(planners["gcrlb_lm"], planners["crlb_lm"]),
        "sensor_count": {str(n): _loop_summary(counts[n]) for n in SENSOR_COUNTS},
        "accuracy": {"equal": summary["gcrlb_lm"], "unequal": _loop_summary(unequal)},
    }
    report["goals"] = {
        "planner_ordering": summary["gcrlb_lm"]["final_mse"] <= summary["crlb_lm"]["final_mse"]
        < summary["straight_line"]["final_mse"],
        "vukf_below_ekfs": estimators["ml_vukf"]["final_mse"] < min(estimators["ml_ekf"]["final_mse"],
                                                                    estimators["ls_ekf"]["final_mse"]),
        "zero_violations": sum(sum(r.violations.values()) for r in lm_runs) == 0,
        "lm_step_ms_median_le_20": summary["gcrlb_lm"]["step_ms_median"] <= LM_STEP_GOAL_MS,
    }
    return report, {"estimators": estimates, "planners": planners, "sensor_count": counts, "unequal": unequal}


def format_report(report: dict) -> str:
    """The tables of every experiment and the goals."""
    s = report["scenario"]
    lines = [f"zuo2021 AOA benchmark: {report['runs']} paired runs from seed {report['seed']}, {s['steps']} steps of "
             f"{s['step_s']:g} s, UAVs at {s['speed_mps']:g} m/s turning <= {s['max_turn_deg']:g} deg/step",
             "", "Estimators (Fig. 2; 3 UAVs flying straight at the target's start), position error m^2:",
             f"{'estimator':<16}{'final MSE':>12}{'final median':>14}{'MSE over time':>15}"]
    for name, e in report["estimators"].items():
        lines.append(f"{name:<16}{e['final_mse']:>12.4g}{e['final_se_median']:>14.4g}{e['mean_mse']:>15.4g}")

    def loop_table(title: str, rows: dict[str, dict], label: str) -> None:
        lines.extend(["", title, f"{label:<16}{'final MSE':>12}{'final median':>14}{'MSE over time':>15}"
                      f"{'bound':>11}{'violations':>12}{'step ms':>9}{'IQR':>12}{'p99':>8}{'LM iter':>9}"])
        for name, p in rows.items():
            lines.append(f"{name:<16}{p['final_mse']:>12.4g}{p['final_se_median']:>14.4g}{p['mean_mse']:>15.4g}"
                         f"{p['final_bound']:>11.4g}{p['violations']:>12}{p['step_ms_median']:>9.2f}"
                         f"{_iqr(p):>12}{p['step_ms_p99']:>8.2f}{p['iterations_median']:>9.0f}")

    loop_table("Planners (Figs. 3-6; 3 UAVs, VG-UKF estimates), position error m^2:", report["planners"], "planner")
    for name, p in report["paired"].items():
        lines.append(f"  {name}: smaller final error in {p['wins']}/{p['runs']} paired runs, "
                     f"Wilcoxon p = {p['wilcoxon_p']:.3g}")
    ratio = report["step_time_gcrlb_lm_over_crlb_lm"]
    lines.append(f"  plan time gcrlb_lm / crlb_lm, step by step (the planners alternated): {ratio['median']:.2f} "
                 f"median (IQR {ratio['p25']:.2f}-{ratio['p75']:.2f})")
    loop_table("Sensor count (Fig. 7; GCRLB-LM, sigma0 1 deg):", report["sensor_count"], "UAVs")
    loop_table("Sensor accuracy (Fig. 8; GCRLB-LM, sigma0 1/1/1 vs 1/0.8/0.1 deg):", report["accuracy"], "accuracy")
    lines.extend(["", "Goals: " + ", ".join(f"{goal} {'met' if ok else 'NOT met'}" for goal, ok in report["goals"].items())])
    return "\n".join(lines)


def _iqr(row: dict) -> str:
    return f"{row['step_ms_p25']:.2f}-{row['step_ms_p75']:.2f}"


def write_json(report: dict, path: Path) -> None:
    """JSON with ``planners.<name>.{final_mse, violations, step_ms_median}`` and ``estimators.<name>.{final_mse}``."""
    path.write_text(json.dumps(report, indent=2) + "\n")


def write_table(report: dict, directory: Path, written: list[Path] | None = None) -> Path:
    """``aoa.md``: the estimators', planners', sensor-count and accuracy tables, and the goals."""
    loop_columns = ["final MSE m^2", "final median m^2", "MSE over time m^2", "bound m^2", "violations",
                    "step ms (median)", "step ms (IQR)", "step ms (p99)", "LM iterations (median)"]

    def loop_rows(rows: dict) -> list[tuple]:
        return [(name, p["final_mse"], p["final_se_median"], p["mean_mse"], p["final_bound"], p["violations"],
                 p["step_ms_median"], _iqr(p), p["step_ms_p99"], p["iterations_median"]) for name, p in rows.items()]

    estimators = [(name, e["final_mse"], e["final_se_median"], e["mean_mse"]) for name, e in report["estimators"].items()]
    paired = [(name, p["wins"], p["runs"], p["wilcoxon_p"]) for name, p in report["paired"].items()]
    sections = [
        ("Estimators on straight flight (Fig. 2)", ["estimator", "final MSE m^2", "final median m^2",
                                                    "MSE over time m^2"], estimators),
        ("Planners (Figs. 3-6)", ["planner", *loop_columns], loop_rows(report["planners"])),
        ("Paired comparisons of the final squared error", ["pair", "wins", "runs", "Wilcoxon p"], paired),
        ("Sensor count (Fig. 7)", ["UAVs", *loop_columns],
         loop_rows({int(n): row for n, row in report["sensor_count"].items()})),
        ("Sensor accuracy (Fig. 8)", ["accuracy", *loop_columns], loop_rows(report["accuracy"])),
        ("Goals", ["goal", "met"], list(report["goals"].items())),
    ]
    s = report["scenario"]
    return write_markdown(directory, "aoa.md", "gcs-bench aoa: zuo2021 bearing-only tracking", sections,
                          [f"{report['runs']} paired runs from seed {report['seed']}, {s['steps']} steps of "
                           f"{s['step_s']:g} s"], written)


def write_plots(report: dict, records: dict, directory: Path) -> list[Path]:
    """PNG plots: estimator MSE (Fig. 2), trajectories (Figs. 3-5, 8), planner MSE (Fig. 6), sensor count (Fig. 7);
    and the tables (``aoa.md``)."""
    plt = pyplot()
    written: list[Path] = []

    def save(fig, name: str) -> None:
        save_figure(fig, directory, name, written)

    def curves(title: str, series: dict[str, dict], name: str, bounds: bool = False, medians: bool = False) -> None:
        fig, ax = plt.subplots(figsize=(9, 4))
        for label, entry in series.items():
            line, = ax.plot(entry["mse_curve"], label=f"{label} (final {entry['final_mse']:.3g})")
            if bounds and "bound_curve" in entry:
                ax.plot(entry["bound_curve"], "--", color=line.get_color(), linewidth=0.8)
            if medians and "median_curve" in entry:
                ax.plot(entry["median_curve"], ":", color=line.get_color(), linewidth=1.0)
        ax.set_yscale("log")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("position MSE over runs (m$^2$)")
        notes = [note for note, on in (("dashed: GCRLB along the flown paths", bounds),
                                       ("dotted: median squared error", medians)) if on]
        ax.set_title(title + (f" ({'; '.join(notes)})" if notes else ""), fontsize=10)
        ax.legend(fontsize=8)
        save(fig, name)

    def paths(ax, record: LoopRecord, title: str) -> None:
        for i in range(record.vehicle_xy.shape[1]):
            xy = record.vehicle_xy[:, i]
            ax.plot(xy[:, 0], xy[:, 1], linewidth=1.0, label=f"UAV {i + 1}")
            ax.plot([xy[-1, 0], record.target_xy[-1, 0]], [xy[-1, 1], record.target_xy[-1, 1]], ":", color="0.4",
                    linewidth=0.8)
        ax.plot(record.target_xy[:, 0], record.target_xy[:, 1], "k-", linewidth=2.0, label="target")
        ax.set_aspect("equal")
        ax.set_xlabel("east (m)")
        ax.set_ylabel("north (m)")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7, loc="lower right")

    curves("Estimators on straight flight (zuo2021 Fig. 2)", report["estimators"], "aoa_estimators_mse.png", medians=True)
    fig, axes = plt.subplots(1, len(PLANNERS), figsize=(15, 5), sharex=True, sharey=True)
    for ax, (name, recs) in zip(axes, records["planners"].items()):
        paths(ax, recs[0], f"{name}, seed {recs[0].seed} (Figs. 3-5)")
    save(fig, "aoa_trajectories.png")
    curves("Planners (zuo2021 Fig. 6)", report["planners"], "aoa_planners_mse.png", bounds=True)
    curves("GCRLB-LM with 2-6 UAVs (zuo2021 Fig. 7)", {f"{n} UAVs": e for n, e in report["sensor_count"].items()},
           "aoa_sensor_count_mse.png")
    fig, axes = plt.subplots(1, 2, figsize=(11, 5), sharex=True, sharey=True)
    paths(axes[0], records["planners"]["gcrlb_lm"][0], "GCRLB-LM, sigma0 1 / 1 / 1 deg")
    paths(axes[1], records["unequal"][0], "GCRLB-LM, sigma0 1 / 0.8 / 0.1 deg (Fig. 8)")
    save(fig, "aoa_unequal_trajectories.png")
    write_table(report, directory, written)
    return written
