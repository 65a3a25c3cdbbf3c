"""`gcs-bench imm` runs as a process and writes the paired IMM / DUIF comparison."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from scipy.stats import chi2

from gcs.scenarios import load_scenario
from tests.figures import track_error_window
from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_imm_writes_the_paired_comparison(tmp_path: Path) -> None:
    out, plots = tmp_path / "imm.json", tmp_path / "plots"
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "imm", "--runs", "2", "--steps", "40",
                           "--seed", "3", "--json", str(out), "--plots", str(plots)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Wilcoxon" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["filters"]) == {"duif", "imm"}
    # Independent figures (tests/figures.py): the RMSE between the target's own motion over a step and one raw
    # detection's error; the 4-state NEES below the chi-square 99.9% quantile of one step (a consistent filter
    # averages 4).
    floor_m, one_detection_m = track_error_window(load_scenario("wang2012_urban"))
    for metrics in report["filters"].values():
        assert {"rmse_m", "rmse_velocity_mps", "rmse_after_turn_m", "nees", "us_per_step_median"} <= set(metrics)
        assert floor_m < metrics["rmse_m"] < one_detection_m, (metrics, floor_m, one_detection_m)
        assert 1.0 < metrics["nees"] < chi2.ppf(0.999, 4), metrics
    assert 0 <= report["paired"]["imm_better_runs"] <= 2
    assert_pngs(plots, ["imm_rmse.png"])
    (table,) = read_tables(plots / "imm.md").values()
    assert [row["filter"] for row in table] == ["duif", "imm"]
    for row in table:
        assert_close(row["RMSE m"], report["filters"][row["filter"]]["rmse_m"])
        assert_close(row["NEES"], report["filters"][row["filter"]]["nees"])
