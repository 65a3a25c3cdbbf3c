"""`gcs-bench livemap` as a process: a short run, its JSON, plot and table (timings are recorded, not asserted)."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from tests.e2e.processes import script
from benchmarks.tests.markdown_tables import assert_close, assert_pngs, read_tables


def test_bench_livemap_measures_observe_and_snapshots_and_writes_plots_and_table(tmp_path: Path) -> None:
    out, plots = tmp_path / "livemap.json", tmp_path / "plots"
    done = subprocess.run([script("gcs-bench"), "livemap", "--vehicles", "3", "20", "--warm-up", "12",
                           "--seconds", "3", "--json", str(out), "--plots", str(plots)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "3 vehicles: 12 s to fill the trails" in done.stderr  # progress
    report = json.loads(out.read_text())
    assert list(report["vehicles"]) == ["3", "20"]
    for count, row in report["vehicles"].items():
        # per second: 5 nav and 1 report per vehicle, a plan per vehicle, a track and a truth
        assert row["messages_per_s"] == 7 * int(count) + 2
        assert row["trail_points"] == 12 + 3  # one point a second of stamp time
        assert row["observe_us_median"] > 0 and row["decode_us_median"] > 0 and row["snapshot_kib"] > 0
        assert 0 < row["snapshot_ms_median"] <= row["snapshot_ms_p99"]
    assert_pngs(plots, ["livemap_cost.png"])
    rows = read_tables(plots / "livemap.md")["By team size"]
    assert [int(r["vehicles"]) for r in rows] == [3, 20]
    for row in rows:
        expected = report["vehicles"][row["vehicles"]]
        assert_close(row["observe us"], expected["observe_us_median"])
        assert_close(row["snapshot ms (median)"], expected["snapshot_ms_median"])
        assert_close(row["core share %"], expected["core_share"] * 100)
