"""``gcs-bench soak --plots DIR``: the daemon's memory over the run, and the accounting table."""

from __future__ import annotations

from pathlib import Path

from benchmarks.plots import pyplot, save, write_markdown

__all__ = ["write_plots"]


def write_plots(report: dict, directory: Path) -> list[Path]:
    """``soak_memory.png`` (resident memory of the daemon and its planner against wall time) and ``soak.md``."""
    written: list[Path] = []
    samples = report["memory"]["samples"]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for column, label in ((1, "daemon"), (2, "planner process")):
        points = [(s[0], s[column]) for s in samples if s[column] is not None]
        if points:
            ax.plot([t for t, _ in points], [m for _, m in points], label=label)
    ax.set_xlabel("wall time, s")
    ax.set_ylabel("resident memory, MB")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(f"soak: {report['simulated_s']:.0f} simulated s, {report['faults']['kills']} vehicle kills")
    save(fig, directory, "soak_memory.png", written)
    published, memory = report["published"], report["memory"]
    accounting = [[kind, count] for kind, count in published.items()]
    accounting += [["received by the daemon", report["received"]], ["lost", report["lost"]],
                   ["crashes", report["crashes_total"]]]
    late = report["late"]
    lateness = [["vehicles' reports accepted", late["of"]], ["late (after their step closed)", late["reports"]],
                ["late share %", round(100.0 * late["share"], 3)],
                ["late share with the injected %", round(100.0 * late["share_with_injected"], 3)],
                ["achieved rate (x real time)", round(report["achieved_rate"], 2)]]
    rss = [["daemon", memory["daemon_rss_mb_start"], memory["daemon_rss_mb_end"], memory["daemon_rss_growth_mb"]],
           ["planner process", memory["planner_rss_mb_start"], memory["planner_rss_mb_end"], None]]
    write_markdown(directory, "soak.md", "gcs-bench soak",
                   [("samples published and taken in", ["what", "count"], accounting),
                    ("late reports", ["what", "value"], lateness),
                    ("resident memory", ["process", "start MB", "end MB", "growth MB"], rss)],
                   notes=[report["command"]], written=written)
    return written
