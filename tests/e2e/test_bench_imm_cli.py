"""`gcs bench imm` runs as a process and writes the paired IMM / DUIF comparison."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_imm_writes_the_paired_comparison(tmp_path: Path) -> None:
    out, plots = tmp_path / "imm.json", tmp_path / "plots"
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "bench", "imm", "--runs", "2", "--steps", "40",
                           "--seed", "3", "--json", str(out), "--plots", str(plots)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Wilcoxon" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["filters"]) == {"duif", "imm"}
    for metrics in report["filters"].values():
        assert {"rmse_m", "rmse_velocity_mps", "rmse_after_turn_m", "nees", "us_per_step_median"} <= set(metrics)
        assert 0 < metrics["rmse_m"] < 50 and 0 < metrics["nees"] < 50
    assert 0 <= report["paired"]["imm_better_runs"] <= 2
    assert_pngs(plots, ["imm_rmse.png"])
    (table,) = read_tables(plots / "imm.md").values()
    assert [row["filter"] for row in table] == ["duif", "imm"]
    for row in table:
        assert_close(row["RMSE m"], report["filters"][row["filter"]]["rmse_m"])
        assert_close(row["NEES"], report["filters"][row["filter"]]["nees"])
