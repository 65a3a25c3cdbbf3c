"""`gcs-bench replay` as a process: a short run writes its report."""

from __future__ import annotations

import json
import subprocess

import pytest

from tests.e2e.processes import script
from benchmarks.tests.markdown_tables import assert_close, assert_pngs, number, read_tables


def test_bench_replay_reports_its_speed_with_progress_plots_and_table(tmp_path) -> None:
    out, plots = tmp_path / "replay.json", tmp_path / "plots"
    done = subprocess.run([script("gcs-bench"), "replay", "--duration", "30", "--repeats", "2", "--json", str(out),
                           "--plots", str(plots)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert report["messages"] == {"report": 90, "nav": 450, "truth": 30}
    assert report["tracks"] > 0 and report["realtime_multiple"] > 0
    assert "x real time" in done.stdout
    assert "run 1/2" in done.stderr and "run 2/2" in done.stderr  # progress
    assert_pngs(plots, ["replay_speed.png"])
    tables = read_tables(plots / "replay.md")
    (speed,) = tables["Speed"]
    assert_close(speed["x real time (median)"], report["realtime_multiple"])
    assert_close(speed["ms (median)"], report["seconds_median"] * 1e3)
    assert int(speed["tracks"]) == report["tracks"] and speed["goal met"] in ("yes", "no")
    assert [number(row["ms"]) for row in tables["Runs"]] == pytest.approx([s * 1e3 for s in report["seconds"]],
                                                                         rel=1e-3)
