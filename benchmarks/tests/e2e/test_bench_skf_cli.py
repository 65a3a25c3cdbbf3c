"""`gcs-bench skf` runs as a process, prints Table 1's columns and writes the documented JSON keys."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_skf_writes_table_1_json(tmp_path: Path) -> None:
    out, plots = tmp_path / "skf.json", tmp_path / "plots"
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "skf", "--runs", "2", "--seed", "5",
                           "--json", str(out), "--plots", str(plots)], capture_output=True, text=True, timeout=600)
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
    assert_pngs(plots, ["skf_rms.png"])
    (table,) = read_tables(plots / "skf.md").values()
    ours = [row for row in table if not row["method"].startswith("paper ")]
    assert [row["method"] for row in ours] == list(methods)
    for row in ours:
        for column, key in (("R_x m", "rms_x"), ("R_y m", "rms_y"), ("R_vx m/s", "rms_vx"), ("R_vy m/s", "rms_vy")):
            assert_close(row[column], methods[row["method"]][key])


def test_bench_skf_rejects_an_unknown_method() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "skf", "--runs", "1", "--method", "ekf"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "invalid choice" in done.stderr
