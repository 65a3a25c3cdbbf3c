"""`gcs-bench demo` runs gcs demo and the in-process loop on the same seeds and writes the documented JSON."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.stats import wilcoxon


def test_bench_demo_compares_the_demo_with_the_in_process_loop(tmp_path: Path) -> None:
    out = tmp_path / "demo.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "demo", "--runs", "2", "--seed", "3", "--duration", "30",
         "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "demo / in process" in done.stdout
    report = json.loads(out.read_text())
    for mode in ("demo", "in_process"):
        means, runs = report[mode], report["per_seed"][mode]
        assert len(runs) == 2 and all(r["steps"] == 30 for r in runs)
        assert means["seen_any_mean"] == pytest.approx(sum(r["seen_any"] for r in runs) / 2)
        assert all(0 <= r["seen_any"] <= 30 and max(r["seen_per_uav"]) <= r["seen_any"] for r in runs)
        assert len(means["seen_per_uav_mean"]) == 3
    assert report["ratios"]["seen_any"] == pytest.approx(report["demo"]["seen_any_mean"]
                                                         / report["in_process"]["seen_any_mean"])
    assert "seed 4: demo seen by any" in done.stderr
    assert "paired Wilcoxon p" in done.stdout
    seen = {mode: [r["seen_any"] for r in report["per_seed"][mode]] for mode in ("demo", "in_process")}
    expected = 1.0 if seen["demo"] == seen["in_process"] else wilcoxon(seen["demo"], seen["in_process"]).pvalue
    assert report["paired_p"]["seen_any"] == pytest.approx(expected, nan_ok=True)
    assert len(report["paired_p"]["seen_per_uav"]) == 3


def test_bench_demo_flies_the_scenario_asked_for_in_both_loops_and_scores_many_targets_by_gospa(tmp_path) -> None:
    out = tmp_path / "demo.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "demo", "--scenario", "multitarget_urban", "--runs", "1",
         "--duration", "20", "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert report["scenario"] == "multitarget_urban" and report["many_targets"] is True
    (demo_run,), (loop_run,) = report["per_seed"]["demo"], report["per_seed"]["in_process"]
    assert demo_run["scenario"] == "multitarget_urban" and demo_run["steps"] == loop_run["steps"] == 20
    # Both loops scored their steps against the recorded truths (GOSPA against the five cars)
    assert all(r["rmse_m"] is not None and math.isfinite(r["rmse_m"]) and r["rmse_m"] >= 0.0
               for r in (demo_run, loop_run))
    assert "GOSPA mean (m)" in done.stdout
