"""`gcs-bench federation --processes` runs real daemons and teams over a router and writes the documented JSON."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

STEPS = 20


def test_bench_federation_processes_members_see_each_other_and_publish(tmp_path: Path) -> None:
    out = tmp_path / "processes.json"
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.cli", "federation", "--processes", "--members", "2", "--uavs-per-member",
         "2", "--steps", str(STEPS), "--seed", "3", "--json", str(out)],
        capture_output=True, text=True, timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(out.read_text())
    config = report["config"]
    assert (config["members"], config["uavs_per_member"], config["steps"]) == (2, 2, STEPS)
    assert config["processes"] is True and config["central"] is False
    assert "no central daemon (--no-central implied)" in done.stdout
    assert [m["member"] for m in report["members"]] == ["m0", "m1"]
    for member in report["members"]:
        assert member["others_seen"] == 1, member  # each daemon holds the other's liveliness token
        assert member["counters"]["federation.heard"] > 0, member  # and took in its MemberTracks
        assert member["steps"] == STEPS, member  # one step per stamp of the teams' common clock
        assert member["federation_bytes_per_s"] > 0.0, member
        spread = member["decision_ms"]
        assert spread["n"] == STEPS - member["undecided"] and spread["max"] >= spread["p99"] >= spread["median"] > 0
        assert f"| {member['member']} | 1 | {STEPS} ({member['planned']}) |" in done.stdout
    summary = report["summary"]
    assert summary["every_member_sees_all"] is True and summary["steps"] == 2 * STEPS
    assert summary["federation_bytes_per_s_max"] == max(m["federation_bytes_per_s"] for m in report["members"])
    assert set(report["exit_codes"]) == {"router", "m0", "m1", "m0-team", "m1-team"}
    assert set(report["exit_codes"].values()) <= {0, 130}  # stopped by SIGINT, as a user would


def test_bench_federation_processes_refuses_a_dead_member() -> None:
    done = subprocess.run([sys.executable, "-m", "benchmarks.cli", "federation", "--processes", "--kill", "1,10"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--kill" in done.stderr and "Traceback" not in done.stderr
