"""`gcs-bench aoa` runs as a process and writes the documented JSON keys and PNG plots."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_aoa_writes_json_and_plots(tmp_path: Path) -> None:
    out, plots = tmp_path / "aoa.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "aoa", "--runs", "2", "--steps", "8", "--seed", "5",
         "--json", str(out), "--plots", str(plots)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "Planners" in done.stdout and "Goals:" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["planners"]) == {"gcrlb_lm", "crlb_lm", "straight_line"}
    for metrics in report["planners"].values():
        assert {"final_mse", "violations", "step_ms_median"} <= set(metrics)
        assert metrics["final_mse"] > 0 and metrics["violations"] == 0
        assert len(metrics["mse_curve"]) == 8
    assert report["planners"]["gcrlb_lm"]["step_ms_median"] > 0
    for metrics in report["planners"].values():
        assert metrics["step_ms_p25"] <= metrics["step_ms_median"] <= metrics["step_ms_p75"] <= metrics["step_ms_p99"]
    ratio = report["step_time_gcrlb_lm_over_crlb_lm"]
    assert 0 < ratio["p25"] <= ratio["median"] <= ratio["p75"]
    assert f"crlb_lm, step by step (the planners alternated): {ratio['median']:.2f}" in done.stdout
    assert set(report["estimators"]) == {"ml_vukf", "ml_ekf", "ls_ekf", "gcrlb"}
    assert all(e["final_mse"] > 0 for e in report["estimators"].values())
    assert set(report["sensor_count"]) == {"2", "3", "4", "5", "6"}
    assert all(row["violations"] == 0 for row in report["sensor_count"].values())
    assert report["accuracy"]["unequal"]["violations"] == 0 and report["goals"]["zero_violations"]
    assert_pngs(plots, ["aoa_estimators_mse.png", "aoa_trajectories.png", "aoa_planners_mse.png",
                        "aoa_sensor_count_mse.png", "aoa_unequal_trajectories.png"])
    tables = read_tables(plots / "aoa.md")
    for row in tables["Planners (Figs. 3-6)"]:
        metrics = report["planners"][row["planner"]]
        assert_close(row["final MSE m^2"], metrics["final_mse"])
        assert_close(row["step ms (median)"], metrics["step_ms_median"])
        assert int(row["violations"]) == metrics["violations"]
    assert [row["planner"] for row in tables["Planners (Figs. 3-6)"]] == list(report["planners"])
    for row in tables["Estimators on straight flight (Fig. 2)"]:
        assert_close(row["final MSE m^2"], report["estimators"][row["estimator"]]["final_mse"])
    assert [int(row["UAVs"]) for row in tables["Sensor count (Fig. 7)"]] == [2, 3, 4, 5, 6]
