"""``gcs-bench daemon --plots``: the rate search and the summary as PNG figures, and the tables in markdown."""

from __future__ import annotations

from pathlib import Path

from benchmarks.plots import pyplot, save, write_markdown

__all__ = ["write_plots"]


def write_plots(report: dict, directory: Path) -> list[Path]:
    """``daemon_rate_search.png`` (each trial: offered rate against latency p99, kept up or not),
    ``daemon_summary.png`` (highest rate and latency per vehicle count, against the goals) and ``daemon.md``."""
    plt = pyplot()
    written: list[Path] = []
    goals = report["goals"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for count, row in report["vehicles"].items():
        trials = sorted((t for t in row["trials"] if t["latency_ms_p99"] is not None), key=lambda t: t["rate_per_s"])
        line, = ax.plot([t["rate_per_s"] for t in trials], [t["latency_ms_p99"] for t in trials], "-", linewidth=0.8,
                        label=f"{count} vehicles")
        for passed, marker in ((True, "o"), (False, "x")):
            chosen = [t for t in trials if bool(t["passed"]) is passed]
            ax.plot([t["rate_per_s"] for t in chosen], [t["latency_ms_p99"] for t in chosen], marker,
                    color=line.get_color())
    ax.axvline(goals["reports_per_s"], color="#e53935", linestyle="--", linewidth=1.0, label="goal rate")
    ax.axhline(goals["latency_ms_p99"], color="#e53935", linestyle=":", linewidth=1.0, label="goal p99")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("offered reports/s (o: nothing lost, x: lost or behind)")
    ax.set_ylabel("report-to-command latency p99 (ms)")
    ax.legend(fontsize=8)
    save(fig, directory, "daemon_rate_search.png", written)

    counts = list(report["vehicles"])
    rows = list(report["vehicles"].values())
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    left.bar(range(len(counts)), [r["max_reports_per_s_no_loss"] for r in rows], color="#1e88e5")
    left.set_xticks(range(len(counts)), counts)
    left.axhline(goals["reports_per_s"], color="#e53935", linestyle="--", linewidth=1.0, label="goal")
    left.set_xlabel("vehicles")
    left.set_ylabel("highest reports/s with nothing lost")
    left.legend(fontsize=8)
    for offset, key, label in ((-0.2, "latency_ms_p50", "p50"), (0.2, "latency_ms_p99", "p99")):
        right.bar([i + offset for i in range(len(counts))], [r[key] or 0.0 for r in rows], 0.4, label=label)
    right.set_xticks(range(len(counts)), counts)
    right.axhline(goals["latency_ms_p99"], color="#e53935", linestyle="--", linewidth=1.0, label="goal p99")
    right.set_xlabel("vehicles")
    right.set_ylabel("latency less the planner's solve (ms)")
    right.legend(fontsize=8)
    save(fig, directory, "daemon_summary.png", written)

    table = [(int(count), r["max_reports_per_s_no_loss"], r["latency_ms_p50"], r["latency_ms_p99"],
              r["latency_at_reports_per_s"], r["visibility_ms_median"], r["solve_ms_median"], r["solve_ms_p99"])
             for count, r in report["vehicles"].items()]
    trials = [(int(count), t["rate_per_s"], t["achieved_per_s"], t["accepted"], t["published"], t["latency_ms_p50"],
               t["latency_ms_p99"], t["passed"]) for count, r in report["vehicles"].items() for t in r["trials"]]
    write_markdown(directory, "daemon.md", "gcs-bench daemon", [
        ("By vehicle count", ["vehicles", "max reports/s", "latency p50 ms", "latency p99 ms", "at reports/s",
                              "visibility ms", "solve ms (median)", "solve ms (p99)"], table),
        ("Goals", ["goal", "met"], [(f"{goals['reports_per_s']:,} reports/s with no loss", goals["rate_met"]),
                                    (f"p99 <= {goals['latency_ms_p99']:g} ms", goals["latency_met"])]),
        ("Trials of the rate search", ["vehicles", "offered /s", "achieved /s", "accepted", "published",
                                       "latency p50 ms", "latency p99 ms", "kept up"], trials),
    ], [report["command"] or "gcs-bench daemon", f"machine: {report['machine']}",
        f"load average {report['load_average']['start']} at start, {report['load_average']['end']} at the end"],
       written)
    return written
