"""`gcs bench skf` runs as a process, prints Table 1's columns and writes the documented JSON keys."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_skf_writes_table_1_json(tmp_path: Path) -> None:
    out = tmp_path / "skf.json"
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "bench", "skf", "--runs", "2", "--seed", "5",
                           "--json", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "R_x m" in done.stdout and "paper skf_cf" in done.stdout
    report = json.loads(out.read_text())
    assert set(report["methods"]) == {"skf_cf", "skf_df", "ins_gps", "filterpy_imm", "filterpy_kf"}
    for metrics in report["methods"].values():
        assert {"rms_x", "rms_y", "rms_vx", "rms_vy", "seconds"} <= set(metrics)
        assert metrics["seconds"] > 0 and 0 < metrics["rms_x"] < 200 and 0 < metrics["rms_vy"] < 50
    methods = report["methods"]
    # The map observations are what the switching filter adds: better than its own one-mode INS/GPS EKF.
    assert methods["skf_cf"]["rms_position"] < methods["ins_gps"]["rms_position"]


def test_bench_skf_rejects_an_unknown_method() -> None:
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "bench", "skf", "--runs", "1", "--method", "ekf"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "invalid choice" in done.stderr
