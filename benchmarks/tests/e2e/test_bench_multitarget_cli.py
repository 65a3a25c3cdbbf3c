"""`gcs-bench multitarget` runs as a process: every method beats the empty track set, the JSON is complete,
bad values are one line and status 2."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

FIGURES = {"gospa", "ospa", "track_breaks", "false_tracks", "id_swaps", "missed", "ms_per_scan"}


def _bench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks.cli", "multitarget", *args],
                          capture_output=True, text=True, timeout=600)


def test_bench_multitarget_writes_json_and_beats_no_tracks(tmp_path: Path) -> None:
    out = tmp_path / "mt.json"
    done = _bench("--runs", "2", "--steps", "30", "--seed", "4", "--json", str(out))
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert set(report["methods"]) == {"gnn", "jpda", "gnn_roads", "jpda_roads", "stonesoup_gnn", "stonesoup_jpda"}
    c = 100.0
    assert "c = 100 m" in done.stdout
    empty = c * math.sqrt(5 / 2.0)  # GOSPA (p = 2, alpha = 2) of no tracks against 5 truths: sqrt(5 c^2 / 2)
    for name, row in report["methods"].items():
        assert FIGURES <= set(row), name
        assert 0.0 < row["gospa"] < empty, (name, row["gospa"])
        assert 0.0 <= row["ospa"] <= c
        assert 0.0 < row["ms_per_scan_p25"] <= row["ms_per_scan"] <= row["ms_per_scan_p75"]
        assert name in done.stdout
    seeds = [s["seed"] for s in report["per_seed"]]
    assert seeds == [4, 5]
    for name, row in report["methods"].items():  # the table's figure is the mean over the seeds
        assert row["gospa"] == pytest.approx(sum(s["methods"][name]["gospa"] for s in report["per_seed"]) / 2)
    assert report["config"]["runs"] == 2 and report["config"]["steps"] == 30 and report["config"]["targets"] == 5
    assert set(report["paired_tests"]) == {"gnn_vs_stonesoup_gnn", "jpda_vs_stonesoup_jpda",
                                           "gnn_roads_vs_stonesoup_gnn", "jpda_roads_vs_stonesoup_jpda"}
    for pair, test in report["paired_tests"].items():  # the paired figures are the per-seed ones
        ours, peer = pair.split("_vs_")
        for figure, key in (("gospa", "mean_difference_m"), ("id_swaps", "swaps_mean_difference")):
            differences = [s["methods"][ours][figure] - s["methods"][peer][figure] for s in report["per_seed"]]
            assert test[key] == pytest.approx(sum(differences) / 2), (pair, figure)

    for ours in ("jpda", "jpda_roads"):  # the per-scan ratios' median and IQR
        ratio = report[f"speed_ratio_stonesoup_jpda_over_{ours}"]
        assert 0.0 < ratio["p25"] <= ratio["median"] <= ratio["p75"]
        assert f"stonesoup_jpda / {ours} = {ratio['median']:.1f}x" in done.stdout
    assert len(report["clutter_density_per_m_rad2"]) == 2 and min(report["clutter_density_per_m_rad2"]) > 0.0


def test_bench_multitarget_no_peers_runs_ours_only(tmp_path: Path) -> None:
    out = tmp_path / "mt.json"
    done = _bench("--runs", "1", "--steps", "15", "--targets", "3", "--no-peers", "--json", str(out))
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    assert set(report["methods"]) == {"gnn", "jpda", "gnn_roads", "jpda_roads"}
    assert report["paired_tests"] == {} and report["speed_ratio_stonesoup_jpda_over_jpda"] is None


@pytest.mark.parametrize(("option", "value"), [("--runs", "0"), ("--pd", "1.5"), ("--clutter", "-1"),
                                                ("--targets", "0")])
def test_bench_multitarget_bad_value_is_one_line_and_status_2(option: str, value: str) -> None:
    done = _bench(option, value)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and option in lines[0] and value in lines[0], done.stderr
    assert "Traceback" not in done.stderr
