"""`gcs-bench autopilots` runs as a process and writes the documented JSON keys, paired by seed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest


def test_bench_autopilots_writes_each_personality_against_the_ideal(tmp_path: Path) -> None:
    out = tmp_path / "autopilots.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "autopilots", "--runs", "2", "--duration", "40", "--seed", "5",
         "--compare-pursuit", "--identify", "--workers", "2", "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "course error median" in done.stdout and "arduplane (lead)" in done.stdout
    report = json.loads(out.read_text())
    names = {"ideal", "arduplane", "px4"}
    assert set(report["personalities"]) == names and set(report["steering_pursuit"]) == names
    ideal = report["personalities"]["ideal"]
    for encoding in ("personalities", "steering_pursuit"):
        for name, metrics in report[encoding].items():
            assert {"course_error_deg_median", "seen_any_mean", "rmse_m"} <= set(metrics)
            assert metrics["seeds"] == [5, 6] and metrics["seen_any_mean"] == sum(metrics["seen_any"]) / 2
            assert 0 <= metrics["seen_any_mean"] <= 40 and len(metrics["seen_per_uav_mean"]) == 3
            assert 0.0 <= metrics["course_error_deg_median"] <= metrics["course_error_deg_p90"] <= 180.0
            assert metrics["seen_any_ratio"] == pytest.approx(metrics["seen_any_mean"] / ideal["seen_any_mean"])
            assert metrics["rmse_ratio"] == pytest.approx(metrics["rmse_m"] / ideal["rmse_m"])
            assert 0.0 < metrics["p_vs_ideal"] <= 1.0
    assert ideal["p_vs_ideal"] == 1.0 and ideal["seen_any_ratio"] == 1.0  # the reference against itself
    loops = report["course_loops"]
    assert set(loops) == {"ideal", "arduplane"}  # px4 takes carrots: no GUIDED_CHANGE_HEADING step to identify
    assert loops["arduplane"]["identified"]["gain_per_s"] < loops["ideal"]["identified"]["gain_per_s"]
    assert "px4 (lead) seed 6" in done.stderr  # progress
