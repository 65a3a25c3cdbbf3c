"""``--plots DIR`` for the navigation benchmarks: ``gcs-bench skf``, ``gcs-bench imm`` and
``gcs-bench urban --gps-denied``.

Each writes a bar chart of its errors per method and a markdown table holding the
numbers of its JSON report (:mod:`benchmarks.plots`).
"""

from __future__ import annotations

from pathlib import Path

from benchmarks.plots import pyplot, save, write_markdown

__all__ = ["write_skf_plots", "write_imm_plots", "write_gps_denied_plots"]


def _bars(ax, labels: list[str], series: dict[str, list[float]], ylabel: str) -> None:
    """Grouped bars: one group per label, one bar per series."""
    width = 0.8 / max(len(series), 1)
    for k, (name, values) in enumerate(series.items()):
        ax.bar([i + (k - (len(series) - 1) / 2) * width for i in range(len(labels))], values, width, label=name)
    ax.set_xticks(range(len(labels)), labels, rotation=20, ha="right")
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)


def write_skf_plots(report: dict, directory: Path) -> list[Path]:
    """``skf_rms.png`` (Table 1's R_x, R_y, R_vx, R_vy per method, with the paper's rows) and ``skf.md``."""
    written: list[Path] = []
    rows = [("ours", name, m) for name, m in report["methods"].items()]
    rows += [("paper", name, m) for name, m in report["paper"].items()]
    labels = [f"{name}" if source == "ours" else f"paper {name}" for source, name, _ in rows]
    plt = pyplot()
    fig, (position, velocity) = plt.subplots(1, 2, figsize=(11, 4))
    _bars(position, labels, {"R_x": [m["rms_x"] for *_, m in rows], "R_y": [m["rms_y"] for *_, m in rows]},
          "RMS position error, m")
    _bars(velocity, labels, {"R_vx": [m["rms_vx"] for *_, m in rows], "R_vy": [m["rms_vy"] for *_, m in rows]},
          "RMS velocity error, m/s")
    fig.suptitle(f"feng2019 Table 1 rebuilt: {report['runs']} Monte Carlo runs")
    save(fig, directory, "skf_rms.png", written)
    table = [[label, m["rms_x"], m["rms_y"], m["rms_vx"], m["rms_vy"], m.get("nees_position"), m["seconds"]]
             for label, (_, _, m) in zip(labels, rows)]
    write_markdown(directory, "skf.md", "gcs-bench skf: feng2019 Table 1",
                   [("RMS errors and time per run", ["method", "R_x m", "R_y m", "R_vx m/s", "R_vy m/s",
                                                     "NEES (2 dof)", "s/run"], table)],
                   notes=[f"{report['runs']} runs from seed {report['seed']}; the paper's times are another "
                          "machine's MATLAB"], written=written)
    return written


def write_imm_plots(report: dict, directory: Path) -> list[Path]:
    """``imm_rmse.png`` (overall, after turns, on straights, per filter) and ``imm.md``."""
    written: list[Path] = []
    filters = report["filters"]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    parts = {"overall": "rmse_m", "after turns": "rmse_after_turn_m", "straight": "rmse_straight_m"}
    _bars(ax, list(parts), {name: [m[key] for key in parts.values()] for name, m in filters.items()},
          "position RMSE, m")
    ax.set_title(f"street-following target, {report['runs']} paired runs")
    save(fig, directory, "imm_rmse.png", written)
    table = [[name, m["rmse_m"], m["rmse_velocity_mps"], m["rmse_after_turn_m"], m["rmse_straight_m"], m["nees"],
              m["us_per_step_median"]] for name, m in filters.items()]
    paired = report["paired"]
    write_markdown(directory, "imm.md", "gcs-bench imm: IMM (CV + coordinated turn) vs the DUIF",
                   [("errors, consistency and time", ["filter", "RMSE m", "velocity RMSE m/s", "after turns m",
                                                      "straight m", "NEES", "us/step (median)"], table)],
                   notes=[f"IMM below DUIF in {paired['imm_better_runs']} of {report['runs']} runs, Wilcoxon "
                          f"p = {paired['wilcoxon_p']:.2g}"], written=written)
    return written


def write_gps_denied_plots(report: dict, directory: Path) -> list[Path]:
    """``urban_gps_denied.png`` (target RMSE overall and in outages per navigation) and ``urban_gps_denied.md``."""
    written: list[Path] = []
    planners = report["planners"]
    plt = pyplot()
    fig, axes = plt.subplots(1, len(planners), figsize=(6 * len(planners), 4), squeeze=False)
    table = []
    for ax, (planner, entry) in zip(axes[0], planners.items()):
        navs = entry["navigation"]
        _bars(ax, list(navs), {"target RMSE": [m["rmse_m"] for m in navs.values()],
                               "target RMSE in outages": [m["rmse_outage_m"] for m in navs.values()],
                               "navigation RMSE without fix": [m["nav_rmse_outage_m"] for m in navs.values()]}, "m")
        ax.set_title(f"planner {planner}")
        table += [[planner, nav, m["rmse_m"], m["rmse_outage_m"], m["nav_rmse_outage_m"], m["outage_steps_mean"],
                   m["seen_any_mean"]] for nav, m in navs.items()]
    save(fig, directory, "urban_gps_denied.png", written)
    write_markdown(directory, "urban_gps_denied.md", "gcs-bench urban --gps-denied",
                   [("target and navigation errors", ["planner", "navigation", "target RMSE m", "in outages m",
                                                      "navigation RMSE without fix m", "outage steps (mean)",
                                                      "seen by any (mean)"], table)],
                   notes=[f"{report['runs']} paired runs from seed {report['seed']}; zones "
                          + ", ".join(z["name"] for z in report["gps_denied"])], written=written)
    return written
