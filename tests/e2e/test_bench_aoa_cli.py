"""`gcs bench aoa` runs as a process and writes the documented JSON keys and PNG plots."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_aoa_writes_json_and_plots(tmp_path: Path) -> None:
    out, plots = tmp_path / "aoa.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "gcs.cli", "bench", "aoa", "--runs", "2", "--steps", "8", "--seed", "5",
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
    assert set(report["estimators"]) == {"ml_vukf", "ml_ekf", "ls_ekf", "gcrlb"}
    assert all(e["final_mse"] > 0 for e in report["estimators"].values())
    assert set(report["sensor_count"]) == {"2", "3", "4", "5", "6"}
    assert all(row["violations"] == 0 for row in report["sensor_count"].values())
    assert report["accuracy"]["unequal"]["violations"] == 0 and report["goals"]["zero_violations"]
    for name in ("aoa_estimators_mse.png", "aoa_trajectories.png", "aoa_planners_mse.png",
                 "aoa_sensor_count_mse.png", "aoa_unequal_trajectories.png"):
        assert (plots / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
