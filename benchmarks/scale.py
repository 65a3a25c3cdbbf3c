"""``gcs-bench scale``: what the many-target loop costs as targets and UAVs grow.

For every team size ``V`` and target count ``N`` asked for (``gcs-bench scale``: 3 and
10 UAVs, 1, 5 and 20 targets) one closed-loop run of :func:`benchmarks.sharing.fly_run` in its chosen mode
(``assign``: each UAV assigned one track, then each track planned for by its UAVs),
on the scene of ``gcs-bench multitarget`` with ``N`` targets
(:func:`benchmarks.multitarget.make_scene`) and ``V`` UAVs: the scenario's three, then
more on a ring (:func:`benchmarks.urban.with_vehicles` for their airframes and sensors,
:func:`benchmarks.multitarget.orbits` for where they start). Per run:

* **decision time**: per step, the engine's decision step (the tracker's scan of every UAV's
  detections, the tracks and their predictions) and the team plan together, median and p99
  (``time.perf_counter`` around each, here);
* **ingest rate**: the detections (clutter included) the engine fused per second of
  its decision steps' time, ``sum(detections) / sum(scan time)``;
* **memory**: the peak of the Python and numpy allocations over a second pass of the
  same run (``tracemalloc``, which slows the code it watches, so that pass is not timed),
  against the allocations held before it started;
* **seen**: each target's steps in some UAV's field, mean and worst over the targets.
"""

from __future__ import annotations

import json
import tracemalloc
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks import sharing
from benchmarks.multitarget import BenchConfig

__all__ = ["MODE", "run_benchmark", "format_report", "write_json"]

MODE = "assign"
"""The chosen way of sharing UAVs between targets (``gcs-bench sharing``, docs/benchmarks.md)."""


def _cell(world, scenario, targets: int, uavs: int, scene: BenchConfig, seed: int) -> dict:
    """One (targets, UAVs) run, timed, then once more under ``tracemalloc``."""
    from benchmarks.urban import with_vehicles

    team = with_vehicles(scenario, uavs)
    run_config = sharing.SharingConfig(replace(scene, targets=targets))
    run = sharing.fly_run(MODE, world, team, seed, run_config)
    tracemalloc.start()
    held = tracemalloc.get_traced_memory()[0]
    sharing.fly_run(MODE, world, team, seed, run_config)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    ms = 1e3 * np.asarray(run.decision_seconds)
    scan_s = float(np.sum(run.scan_seconds))
    return {"targets": targets, "uavs": uavs, "steps": len(ms),
            "decision_ms_median": float(np.median(ms)), "decision_ms_p99": float(np.percentile(ms, 99)),
            "scan_ms_median": 1e3 * float(np.median(run.scan_seconds)),
            "plan_ms_median": 1e3 * float(np.median(run.plan_seconds)) if run.plan_seconds else None,
            "detections": run.detections,
            "ingest_detections_per_s": run.detections / scan_s if scan_s > 0.0 else None,
            "memory_peak_mib": (peak - held) / 2**20,
            "target_steps_mean": float(run.target_steps.mean()), "target_steps_min": int(run.target_steps.min()),
            "gospa": run.gospa_m}


def run_benchmark(scene: BenchConfig, seed: int, targets: Sequence[int], uavs: Sequence[int],
                  progress: Callable[[str], None] = lambda _: None) -> dict:
    """Every (targets, UAVs) pair on seed ``seed``; the report as a dict."""
    from gcs.config.world import build_world
    from gcs.scenarios import load_scenario

    scenario = load_scenario("wang2012_urban")
    world = build_world(scenario)
    cells = []
    for v in uavs:
        for n in targets:
            cell = _cell(world, scenario, n, v, scene, seed)
            progress(f"{n} targets, {v} UAVs: decision {cell['decision_ms_median']:.1f} ms median, "
                     f"{cell['memory_peak_mib']:.1f} MiB")
            cells.append(cell)
    return {"mode": MODE, "seed": seed, "steps": scene.steps, "pd": scene.pd, "clutter": scene.clutter,
            "cells": cells}


def format_report(report: dict) -> str:
    """The report as a markdown table."""
    lines = [f"gcs-bench scale: mode {report['mode']}, seed {report['seed']}, {report['steps']} steps of 1 s, "
             f"pd {report['pd']:g}, clutter {report['clutter']:g} per UAV and scan", "",
             "| targets | UAVs | decision ms median | p99 | of it, scan ms | plan ms | ingest (detections/s) | "
             "memory peak (MiB) | target in field, mean / worst | GOSPA (m) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for c in report["cells"]:
        plan = "-" if c["plan_ms_median"] is None else f"{c['plan_ms_median']:.1f}"
        ingest = "-" if c["ingest_detections_per_s"] is None else f"{c['ingest_detections_per_s']:,.0f}"
        lines.append(f"| {c['targets']} | {c['uavs']} | {c['decision_ms_median']:.1f} | {c['decision_ms_p99']:.1f} | "
                     f"{c['scan_ms_median']:.2f} | {plan} | {ingest} | {c['memory_peak_mib']:.1f} | "
                     f"{c['target_steps_mean']:.1f} / {c['target_steps_min']} | {c['gospa']:.1f} |")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    path.write_text(json.dumps(report, indent=2) + "\n")
