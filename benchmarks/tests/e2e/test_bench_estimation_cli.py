"""`gcs-bench estimation` runs as a process, prints its tables and writes the documented JSON keys."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_estimation_writes_the_documented_json_plots_and_table(tmp_path: Path) -> None:
    out, plots = tmp_path / "estimation.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "estimation", "--runs", "3", "--steps", "20",
         "--table-runs", "1", "--scenes", "1", "--seed", "5", "--json", str(out), "--plots", str(plots)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "RMSE/sqrt(PCRLB)" in done.stdout and "speed-up" in done.stdout
    report = json.loads(out.read_text())
    keys = {"rmse_m", "rmse_over_pcrlb", "nees", "us_per_step_median", "us_per_step_q25", "us_per_step_q75"}
    # the daemon's update, its numpy form, the paper's form, the oracle
    for name in ("duif", "duif_numpy", "duif_eq13", "filterpy_ukf"):
        metrics = report["methods"][name]
        assert set(metrics) == keys
        assert all(math.isfinite(v) and v > 0 for v in metrics.values())
        assert metrics["us_per_step_q25"] <= metrics["us_per_step_median"] <= metrics["us_per_step_q75"]
    for name in ("multitarget", "duif_many", "filterpy_ukf"):  # 20 targets
        assert set(report["many"]["methods"][name]) == keys
    for part in (report, report["many"]):
        ratios = part["speedup_vs_filterpy"]
        assert "filterpy_ukf" not in ratios
        assert all(r["ratio_q25"] <= r["ratio_median"] <= r["ratio_q75"] for r in ratios.values())
    assert [row["vehicles"] for row in report["table"]] == [1, 3, 10, 30]
    assert len(report["rmse_by_step_m"]["duif"]) == len(report["rmse_by_step_m"]["pcrlb_m"]) == 20
    assert_pngs(plots, ["estimation_rmse.png", "estimation_speed.png"])
    tables = read_tables(plots / "estimation.md")
    methods = {row["method"]: row for row in tables["3 vehicles"]}
    assert set(methods) == {"duif", "duif_numpy", "duif_eq13", "filterpy_ukf"}
    assert "duif: the daemon's update: iterated_update after the prediction" in done.stdout
    for name, row in methods.items():
        metrics = report["methods"][name]
        for column, key in (("RMSE m", "rmse_m"), ("RMSE / sqrt(PCRLB)", "rmse_over_pcrlb"), ("NEES", "nees"),
                            ("us/step median", "us_per_step_median"), ("us/step q75", "us_per_step_q75")):
            assert_close(row[column], metrics[key])
    for row in tables["20 targets"]:
        assert_close(row["us/step median"], report["many"]["methods"][row["method"]]["us_per_step_median"])
    for row, expected in zip(tables["By vehicle count"], report["table"], strict=True):
        assert int(row["vehicles"]) == expected["vehicles"]
        assert_close(row["DUIF us/step"], expected["duif"]["us_per_step_median"])
        assert_close(row["UKF RMSE m"], expected["filterpy_ukf"]["rmse_m"])


def test_bench_rejects_a_bad_argument() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "estimation", "--runs", "0"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "--runs" in done.stderr
