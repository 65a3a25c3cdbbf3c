"""`gcs-bench sharing` flies every mode on the same seeds and writes the documented JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.stats import wilcoxon


def test_bench_sharing_reports_every_mode_with_paired_tests(tmp_path: Path) -> None:
    out = tmp_path / "sharing.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "sharing", "--runs", "3", "--seed", "4", "--steps", "25",
         "--targets", "3", "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "| sum vs assign |" in done.stdout and "seed 6:" in done.stderr
    report = json.loads(out.read_text())
    assert set(report["modes"]) == {"sum", "assign", "orbit"}
    scored = report["config"]["scored_steps"]
    assert scored == 15
    for mode, summary in report["modes"].items():
        rows = [s["modes"][mode] for s in report["per_seed"]]
        assert all(len(r["target_steps"]) == 3 and max(r["target_steps"]) <= scored for r in rows)
        assert all(r["target_steps_min"] == min(r["target_steps"]) for r in rows)
        assert summary["target_steps_min"] == pytest.approx(sum(r["target_steps_min"] for r in rows) / 3)
        assert summary["target_steps_min"] <= summary["target_steps_mean"]
        assert len(summary["uav_steps"]) == 3
    assert report["modes"]["orbit"]["plan_ms_median"] is None
    assert report["modes"]["sum"]["plan_ms_median"] > 0.0
    worst = {m: [s["modes"][m]["target_steps_min"] for s in report["per_seed"]] for m in ("sum", "orbit")}
    expected = 1.0 if worst["sum"] == worst["orbit"] else wilcoxon(worst["sum"], worst["orbit"]).pvalue
    assert report["paired_p"]["sum_vs_orbit"]["target_steps_min"] == pytest.approx(expected, nan_ok=True)


def test_bench_sharing_refuses_a_bad_probability() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "sharing", "--pd", "1.5"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--pd" in done.stderr and "Traceback" not in done.stderr
