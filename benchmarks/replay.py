"""``gcs-bench replay``: how many times faster than real time ``gcs replay --process`` estimates.

The recording is made in the benchmark, without a network: the default
scenario's simulated vehicles (:func:`sim_vehicles.recording.record_scene`, loitering,
no ground station) produce their reports, nav reports and the target's truth
for ``duration`` simulated seconds, written with the recorder exactly as
``gcs record`` writes them (receive time = stamp). Then
:func:`gcs.recordings.replay.process` runs on the file several times; the figure is the
recording's stamp span divided by the median processing time. Reading the file
is included (the whole ``--process`` path), planning is not. ``--navigation`` is
replay's (default ``auto``: the reported positions on the default scenario, which
declares no GPS-denied zone); with ``skf`` every nav report goes through its
vehicle's navigation filter, which takes most of the time (4,500 nav reports
against 900 sensor reports in 300 s).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from benchmarks.plots import pyplot, save, write_markdown
from gcs.config import Scenario
from gcs.core.world import World
from gcs.engine.navigation import runs_skf
from gcs.recordings.replay import process
from sim_vehicles.recording import record_scene

__all__ = ["run_benchmark", "format_report", "write_plots"]


def run_benchmark(scenario: Scenario, world: World, duration_s: float = 300.0, repeats: int = 5,
                  seed: int = 0, progress: Callable[[str], None] | None = None, navigation: str = "auto") -> dict:
    """Record, then time ``process`` ``repeats`` times (with ``navigation``: ``gcs replay --navigation``);
    the speed in multiples of real time."""
    say = progress or (lambda _msg: None)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.mcap"
        say(f"simulating {duration_s:g} s of {scenario.name} into a recording")
        counts = record_scene(scenario, world, path, duration_s, seed)
        size = path.stat().st_size
        times, tracks = [], 0
        for repeat in range(repeats):
            start = time.perf_counter()
            result, _, _ = process(path, scenario, navigation=navigation)
            times.append(time.perf_counter() - start)
            tracks = len(result)
            say(f"run {repeat + 1}/{repeats}: {times[-1] * 1e3:.0f} ms, {duration_s / times[-1]:.0f}x real time")
    median = statistics.median(times)
    used = "skf" if runs_skf(navigation, scenario) else "reported"
    return {"scenario": scenario.name, "navigation": navigation if navigation == used else f"{navigation} ({used})", "duration_s": duration_s, "messages": counts, "file_bytes": size,
            "tracks": tracks, "repeats": repeats, "seconds_median": median, "seconds_min": min(times),
            "seconds": times,
            "realtime_multiple": duration_s / median, "goal_realtime_multiple": 1000.0}


def write_plots(result: dict, directory: Path) -> list[Path]:
    """``replay_speed.png`` (each run's multiple of real time against the goal) and ``replay.md``."""
    plt = pyplot()
    written: list[Path] = []
    multiples = [result["duration_s"] / s for s in result["seconds"]]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.bar(range(1, len(multiples) + 1), multiples, color="#1e88e5", label="run")
    ax.axhline(result["realtime_multiple"], color="k", linewidth=1.0, label=f"median {result['realtime_multiple']:.0f}x")
    ax.axhline(result["goal_realtime_multiple"], color="#e53935", linestyle="--", linewidth=1.0,
               label=f"goal {result['goal_realtime_multiple']:.0f}x")
    ax.set_xlabel("run")
    ax.set_ylabel("multiple of real time")
    ax.set_title(f"gcs replay --process on {result['duration_s']:g} s of {result['scenario']}", fontsize=10)
    ax.legend(fontsize=8)
    save(fig, directory, "replay_speed.png", written)
    rows = [(result["scenario"], result["duration_s"], result["tracks"], result["file_bytes"], result["repeats"],
             result["seconds_median"] * 1e3, result["seconds_min"] * 1e3, result["realtime_multiple"],
             result["goal_realtime_multiple"], result["realtime_multiple"] >= result["goal_realtime_multiple"])]
    write_markdown(directory, "replay.md", "gcs-bench replay: replay --process speed", [
        ("Speed", ["scenario", "simulated s", "tracks", "file bytes", "runs", "ms (median)", "ms (min)",
                   "x real time (median)", "goal x", "goal met"], rows),
        ("Runs", ["run", "ms", "x real time"], [(i + 1, s * 1e3, m) for i, (s, m) in
                                                enumerate(zip(result["seconds"], multiples))]),
    ], [f"messages: {', '.join(f'{v} {k}' for k, v in result['messages'].items())}"], written)
    return written


def format_report(result: dict) -> str:
    """The benchmark as a few lines."""
    messages = ", ".join(f"{v} {k}" for k, v in result["messages"].items())
    verdict = "met" if result["realtime_multiple"] >= result["goal_realtime_multiple"] else "NOT met"
    return (f"replay --process --navigation {result.get('navigation', 'skf')} on {result['duration_s']:g} s of "
            f"{result['scenario']} ({messages}; "
            f"{result['file_bytes'] / 1024:.0f} KiB MCAP; {result['tracks']} tracks)\n"
            f"median {result['seconds_median'] * 1e3:.0f} ms over {result['repeats']} runs "
            f"(min {result['seconds_min'] * 1e3:.0f} ms): {result['realtime_multiple']:.0f}x real time "
            f"(goal {result['goal_realtime_multiple']:.0f}x: {verdict})")
