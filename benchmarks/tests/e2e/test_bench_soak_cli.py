"""`gcs-bench soak` as a process, very short: every kind of fault happens, and every sample is accounted for.

The full soak (30 simulated minutes) is measured, not tested: its figures are in
docs/benchmarks.md. Here a minute of 4 vehicles at 10x (about 6 s of flight)
checks the accounting the report is for: every sample on the wire was taken in
by the daemon (accepted or rejected by reason), nothing crashed.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from benchmarks.soak import POST_INGEST
from benchmarks.tests.markdown_tables import assert_pngs, read_tables


def test_a_short_soak_loses_nothing_crashes_nothing_and_reports_memory(tmp_path: Path) -> None:
    out = tmp_path / "soak.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "soak", "--vehicles", "4", "--processes", "2", "--duration", "60",
         "--rate", "10", "--fault-every", "0.3", "--seed", "1", "--planner", "orbit", "--workdir",
         str(tmp_path / "logs"), "--json", str(out), "--plots", str(tmp_path / "plots")],
        capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads(out.read_text())
    assert report["lost"] == 0 and report["crashes_total"] == 0, report
    published, accepted, dropped = report["published"], report["accepted"], report["dropped"]
    ingest_drops = sum(v for k, v in dropped.items() if f"rejected.{k}" not in POST_INGEST)
    assert published["total"] == report["received"] == sum(accepted.values()) + ingest_drops
    assert published["report"] >= 40 and published["nav"] >= 2 * published["report"]  # 1 Hz and 5 Hz, less the kills
    faults = report["faults"]
    assert faults["kills"] >= 1 and faults["silences"] >= 1 and sum(faults["injected"].values()) >= 1
    injected_dropped = {"malformed", "encoding", "future", "stale", "unknown_vehicle", "duplicate"}
    assert {k for k in faults["injected"] if k in injected_dropped} <= set(dropped)  # each counted by its reason
    assert report["errors"] == {} and report["exit_codes"] == {"daemon": 130, "router": 130}  # stopped by its SIGINT
    memory = report["memory"]
    assert memory["daemon_rss_mb_start"] > 0 and memory["daemon_rss_mb_end"] > 0 and memory["samples"]
    assert report["used_in_steps"] > 0 and report["decisions"] > 0
    late = report["late"]  # the vehicles keep one clock through kills and restarts (lockstep)
    assert late["injected"] == faults["injected"].get("late", 0)
    assert late["reports"] == max(0, dropped.get("late", 0) - late["injected"])
    assert late["of"] == accepted["report"] - late["injected"] and late["share"] < 0.01, late
    assert f"late: {late['share']:.2%} of the vehicles' reports" in done.stdout
    simulation = report["simulation"]
    assert simulation["held_steps"] <= simulation["steps"]  # of the processes that ran to the end
    assert_pngs(tmp_path / "plots", ["soak_memory.png"])
    tables = read_tables(tmp_path / "plots" / "soak.md")
    counts = {row["what"]: int(row["count"]) for row in tables["samples published and taken in"]}
    assert {row["what"]: row["value"] for row in tables["late reports"]}["late (after their step closed)"] == \
        str(late["reports"])
    assert counts["total"] == published["total"] and counts["lost"] == 0 and counts["crashes"] == 0
