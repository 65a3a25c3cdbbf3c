"""`gcs-bench daemon` runs as a process: a load process feeds the daemon over loopback Zenoh; the documented JSON.

Timing goals are never asserted (conventions: speed is measured and recorded, not
tested); what is checked is that the run is sound: nothing is lost at the rates
tried, the search found a rate the daemon keeps up with, and every latency and
solve time is positive.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.tests.markdown_tables import assert_close, assert_pngs, number, read_tables

PER_COUNT_KEYS = {"max_reports_per_s_no_loss", "latency_ms_p50", "latency_ms_p99", "solve_ms_median", "solve_ms_p99"}


def test_bench_daemon_writes_the_documented_json_plots_and_table(tmp_path: Path) -> None:
    out, plots = tmp_path / "daemon.json", tmp_path / "plots"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "daemon", "--vehicles", "3", "--seconds", "0.5",
         "--solve-steps", "2", "--json", str(out), "--plots", str(plots)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "max reports/s" in done.stdout and "goal >= 5,000 reports/s" in done.stdout
    report = json.loads(out.read_text())
    assert {"max_reports_per_s_no_loss", "latency_ms_p50", "latency_ms_p99", "latency_vehicles", "machine",
            "goals"} <= set(report)
    assert set(report["vehicles"]) == {"3"} and report["latency_vehicles"] == 3
    row = report["vehicles"]["3"]
    # the load ran 5 below the benchmark's priority (ours: it inherits it), as the table says
    assert report["load_niceness"] == 5 and row["load_nice"] == min(19, os.nice(0) + 5)
    assert "load in a separate process (nice +5)" in done.stdout
    assert PER_COUNT_KEYS <= set(row)
    assert report["max_reports_per_s_no_loss"] == row["max_reports_per_s_no_loss"] > 0
    assert (report["latency_ms_p50"], report["latency_ms_p99"]) == (row["latency_ms_p50"], row["latency_ms_p99"])
    assert 0 < row["latency_ms_p50"] <= row["latency_ms_p99"]
    assert 0 < row["solve_ms_median"] <= row["solve_ms_p99"] and 1 <= row["solve_steps"] <= 2
    assert isinstance(report["goals"]["rate_met"], bool) and isinstance(report["goals"]["latency_met"], bool)
    trials = row["trials"]
    assert trials[0]["rate_per_s"] == 1250 and any(t["passed"] for t in trials)
    for trial in trials + [row["realtime_trial"]]:  # reliable Zenoh: nothing lost even when the daemon fell behind
        assert trial["accepted"] == trial["published"] > 0
        assert trial["rejected"] == trial["late"] == trial["decision_errors"] == 0
        assert trial["steps"] == trial["published"] // 3
    assert row["realtime_trial"]["passed"] is None
    assert_pngs(plots, ["daemon_rate_search.png", "daemon_summary.png"])
    tables = read_tables(plots / "daemon.md")
    (shown,) = tables["By vehicle count"]
    assert int(shown["vehicles"]) == 3
    for column, key in (("max reports/s", "max_reports_per_s_no_loss"), ("latency p50 ms", "latency_ms_p50"),
                        ("latency p99 ms", "latency_ms_p99"), ("solve ms (median)", "solve_ms_median")):
        assert_close(shown[column], row[key])
    assert [number(t["offered /s"]) for t in tables["Trials of the rate search"]] == [t["rate_per_s"] for t in trials]
    assert [t["kept up"] for t in tables["Trials of the rate search"]] == ["yes" if t["passed"] else "no"
                                                                          for t in trials]


@pytest.mark.parametrize("argument", [["--seconds", "0"], ["--load-nice", "20"], ["--load-nice", "-1"]])
def test_bench_daemon_rejects_a_bad_argument(argument: list[str]) -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "daemon", *argument],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert argument[0] in done.stderr


def test_bench_daemon_with_fixed_rates_runs_one_trial_at_each_in_turn(tmp_path: Path) -> None:
    out = tmp_path / "daemon.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "daemon", "--vehicles", "3", "--seconds", "0.5",
         "--solve-steps", "0", "--rates", "600", "300", "600", "--json", str(out)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert report["rates"] == [600, 300, 600] and "--rates 600 300 600" in report["command"]
    trials = report["vehicles"]["3"]["trials"]
    assert [t["rate_per_s"] for t in trials] == [600, 300, 600]
    for trial in trials:
        assert trial["accepted"] == trial["published"] > 0 and trial["latency_ms_p50"] > 0
