"""`gcs bench estimation` runs as a process, prints its tables and writes the documented JSON keys."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path


def test_bench_estimation_writes_the_documented_json(tmp_path: Path) -> None:
    out = tmp_path / "estimation.json"
    done = subprocess.run(
        [sys.executable, "-m", "gcs.cli", "bench", "estimation", "--runs", "3", "--steps", "20",
         "--table-runs", "1", "--seed", "5", "--json", str(out)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "RMSE/sqrt(PCRLB)" in done.stdout and "speed-up" in done.stdout
    report = json.loads(out.read_text())
    for name in ("duif", "filterpy_ukf"):
        metrics = report["methods"][name]
        assert set(metrics) == {"rmse_m", "rmse_over_pcrlb", "nees", "us_per_step_median"}
        assert all(math.isfinite(v) and v > 0 for v in metrics.values())
    assert [row["vehicles"] for row in report["table"]] == [1, 3, 10, 30]


def test_bench_rejects_a_bad_argument() -> None:
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "bench", "estimation", "--runs", "0"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "--runs" in done.stderr
