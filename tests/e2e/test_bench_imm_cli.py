"""`gcs bench imm` runs as a process and writes the paired IMM / DUIF comparison."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_imm_writes_the_paired_comparison(tmp_path: Path) -> None:
    out = tmp_path / "imm.json"
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "bench", "imm", "--runs", "2", "--steps", "40",
                           "--seed", "3", "--json", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Wilcoxon" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["filters"]) == {"duif", "imm"}
    for metrics in report["filters"].values():
        assert {"rmse_m", "rmse_velocity_mps", "rmse_after_turn_m", "nees", "us_per_step_median"} <= set(metrics)
        assert 0 < metrics["rmse_m"] < 50 and 0 < metrics["nees"] < 50
    assert 0 <= report["paired"]["imm_better_runs"] <= 2
