"""`gcs-bench urban` runs as a process, writes the documented JSON keys and PNG plots."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_urban_writes_json_and_plots(tmp_path: Path) -> None:
    out, plots = tmp_path / "urban.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "urban", "--scenario", "nofly_city", "--runs", "3", "--duration", "8",
         "--planners", "sight", "ga_k5", "orbit", "--no-scaling", "--seed", "3", "--workers", "2",
         "--json", str(out), "--plots", str(plots)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "seen by any" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["planners"]) == {"sight", "ga_k5", "orbit"}
    for name, metrics in report["planners"].items():
        assert {"seen_any_mean", "seen_per_uav_mean", "rmse_m", "lost_runs", "violations", "decision_ms_median",
                "decision_ms_p99"} <= set(metrics)
        assert 0 <= metrics["seen_any_mean"] <= 8 and len(metrics["seen_per_uav_mean"]) == 3
        assert metrics["seeds"] == [3, 4, 5] and metrics["seen_any_mean"] == sum(metrics["seen_any"]) / 3
        assert metrics["violations"] == 0 and 0 < metrics["decision_ms_median"] <= metrics["decision_ms_p99"]
        if name != "orbit":  # each against the orbit, paired by seed
            assert 0.0 < metrics["p_vs_orbit"] <= 1.0
        lost = metrics["lost_track"]  # what lost tracks look like: the same errors counted otherwise
        assert lost["runs_over_100"] == metrics["lost_runs"] and lost["runs_over_100"] <= lost["runs_over_50"]
        assert lost["steps_over_100"] <= lost["steps_over_50"] <= lost["steps"] <= 3 * 8
        assert metrics["rmse_m"] <= lost["max_m"] and lost["p95_m"] <= lost["max_m"]
        assert 0.0 <= lost["nees_in_band"] <= 1.0
        assert lost["longest_unseen_max"] == max(lost["longest_unseen"]) <= 8
        assert all(seen <= 8 - unseen for seen, unseen in zip(metrics["seen_any"], lost["longest_unseen"]))
    assert "p_vs_orbit" not in report["planners"]["orbit"]
    assert "TrackEstimate" in report["scored"] and "TrackEstimate" in done.stdout
    assert_pngs(plots, ["urban_trajectories.png", "urban_rmse.png", "urban_observations.png"])
    tables = read_tables(plots / "urban.md")  # no scaling table with --no-scaling
    assert list(tables) == ["Observations and accuracy", "Lost track"]
    table = tables["Observations and accuracy"]
    for row in tables["Lost track"]:
        lost = report["planners"][row["planner"]]["lost_track"]
        assert_close(row["error p95 m"], lost["p95_m"])
        assert int(row["runs over 100 m"]) == lost["runs_over_100"]
        assert int(row["steps over 50 m"]) == lost["steps_over_50"]
        assert_close(row["NEES in 95% band"], lost["nees_in_band"])
    assert [row["planner"] for row in table] == ["sight", "ga_k5", "orbit"]
    for row in table:
        metrics = report["planners"][row["planner"]]
        assert_close(row["seen by any (mean)"], metrics["seen_any_mean"])
        assert_close(row["RMSE m"], metrics["rmse_m"])
        assert_close(row["decision ms (median)"], metrics["decision_ms_median"])
        for cell, value in zip(row["seen per UAV (mean)"].split(" / "), metrics["seen_per_uav_mean"]):
            assert_close(cell, value)
        assert int(row["airspace violations"]) == metrics["violations"]
    assert "seed 3 ga_k5: seen by any" in done.stderr  # progress


def test_bench_urban_gps_denied_writes_the_navigation_comparison(tmp_path: Path) -> None:
    out, plots = tmp_path / "denied.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "urban", "--gps-denied", "--runs", "1", "--duration", "6",
         "--planner", "orbit", "--navigation", "perfect", "--navigation", "reported", "--navigation", "skf",
         "--seed", "3", "--json", str(out), "--plots", str(plots)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "GPS-denied" in done.stdout and "skf below reported" in done.stdout
    report = json.loads(out.read_text())
    assert report["gps_denied"][0]["name"] == "centre"
    navs = report["planners"]["orbit"]["navigation"]
    assert set(navs) == {"perfect", "reported", "skf"}
    for metrics in navs.values():
        assert {"rmse_m", "rmse_outage_m", "nav_rmse_outage_m", "outage_steps_mean"} <= set(metrics)
    assert navs["perfect"]["nav_rmse_outage_m"] == 0.0 and navs["skf"]["nav_rmse_outage_m"] > 0.0
    assert_pngs(plots, ["urban_gps_denied.png"])
    (table,) = read_tables(plots / "urban_gps_denied.md").values()
    assert [row["navigation"] for row in table] == ["perfect", "reported", "skf"]
    for row in table:
        assert_close(row["target RMSE m"], navs[row["navigation"]]["rmse_m"])
        assert_close(row["in outages m"], navs[row["navigation"]]["rmse_outage_m"])
