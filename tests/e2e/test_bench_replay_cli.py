"""`gcs bench replay` as a process: a short run writes its report."""

from __future__ import annotations

import json
import subprocess

from tests.e2e.processes import script


def test_bench_replay_reports_its_speed(tmp_path) -> None:
    out = tmp_path / "replay.json"
    done = subprocess.run([script("gcs"), "bench", "replay", "--duration", "30", "--repeats", "2", "--json", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert report["messages"] == {"report": 90, "nav": 450, "truth": 30}
    assert report["tracks"] > 0 and report["realtime_multiple"] > 0
    assert "x real time" in done.stdout
