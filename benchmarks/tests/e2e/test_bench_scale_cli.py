"""`gcs-bench scale` measures every pair of target count and team size and writes the documented JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_scale_reports_every_pair_with_time_ingest_and_memory(tmp_path: Path) -> None:
    out = tmp_path / "scale.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "scale", "--steps", "12", "--targets", "1", "4",
         "--uavs", "3", "5", "--seed", "2", "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    cells = {(c["targets"], c["uavs"]): c for c in report["cells"]}
    assert set(cells) == {(1, 3), (4, 3), (1, 5), (4, 5)}
    for (targets, uavs), c in cells.items():
        assert f"| {targets} | {uavs} |" in done.stdout
        assert c["steps"] == 12 and c["decision_ms_p99"] >= c["decision_ms_median"] > 0.0
        assert c["memory_peak_mib"] > 0.0
        assert c["target_steps_min"] <= c["target_steps_mean"]
        assert c["scan_ms_median"] <= c["decision_ms_median"]  # every step's decision holds its scan
        assert c["detections"] > 0 and c["ingest_detections_per_s"] > 0.0


def test_bench_scale_refuses_a_team_of_none() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "scale", "--uavs", "0"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--uavs" in done.stderr and "Traceback" not in done.stderr
