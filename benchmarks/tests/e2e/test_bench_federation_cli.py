"""`gcs-bench federation` flies the members and the central daemon on paired seeds and writes the documented JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_bench_federation_reports_members_against_the_central_daemon(tmp_path: Path) -> None:
    out = tmp_path / "federation.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "federation", "--runs", "2", "--steps", "40", "--targets", "3",
         "--members", "2", "--uavs-per-member", "2", "--kill", "1,30", "--seed", "3", "--json", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert report["seeds"] == [3, 4] and report["config"]["kill"] == [1, 30]
    for name in ("federation", "central"):
        summary = report[name]
        assert len(summary["gospa_per_seed"]) == 2
        assert 0.0 <= summary["nees_inside"] <= 1.0
        assert summary["decision_ms"]["p99"] >= summary["decision_ms"]["median"] > 0.0
        assert f"| {name} | {summary['gospa_m']:.1f} |" in done.stdout
    assert report["federation"]["bytes_per_s_max"] > 0.0
    assert "GOSPA federation / central" in done.stdout and "hand-over" in done.stdout


def test_bench_federation_refuses_a_dead_member_outside_the_federation() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "federation", "--members", "2", "--kill", "2,10"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--kill" in done.stderr and "Traceback" not in done.stderr
