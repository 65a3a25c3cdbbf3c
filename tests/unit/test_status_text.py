"""What a user reads of the daemon's status: times, the counters' meanings, the commands' age, the flight line."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np
import pytest

from gcs.daemon.flight_report import FlightReport
from gcs.engine.records import StepRecord
from gcs.daemon.status_text import (COUNTER_FAMILIES, COUNTERS, REJECTIONS, command_age_text, counter_meaning,
                                    format_stamp, format_status, keeps_up)
from protocols.messages import DaemonStatus, TrackSummary, VehicleStatus

ROOT = Path(__file__).resolve().parents[2]
S = 1_000_000_000
NOW = 1_700_000_000 * S  # 2023-11-14T22:13:20Z


def test_a_stamp_is_a_utc_time_with_its_age() -> None:
    assert format_stamp(NOW - 3 * S, NOW) == "2023-11-14T22:13:17Z, 3 s ago"
    assert format_stamp(NOW + 61 * S, NOW).startswith("2023-11-14T22:14:21Z, 61 s ahead of this clock")
    assert format_stamp(None, NOW) == "none"


@pytest.mark.parametrize(("lag_periods", "expected"), [(0.2, True), (0.9, True), (1.1, False), (2.0, False)])
def test_the_loop_keeps_up_while_the_median_age_shows_plans_within_a_period(lag_periods: float,
                                                                            expected: bool) -> None:
    # A plan commanded `lag` after its step and flown for a period (1 s) until the next: the commands' ages,
    # sampled at the steering rate, spread over [lag, lag + T]. The loop keeps up while lag < T.
    step_s, rng = 1.0, np.random.default_rng(5)
    ages_ms = 1000.0 * (lag_periods * step_s + rng.uniform(0.0, step_s, 2000))
    assert keeps_up(float(np.median(ages_ms)), step_s) is expected


def test_the_command_age_text_says_whether_the_machine_keeps_up_with_the_rate() -> None:
    assert command_age_text(800.0, 1400.0, 1.0, 10.0).endswith("the loop keeps up (median under 1.5 decision "
                                                               "periods, 1.5 s)")
    slow = command_age_text(2600.0, 4800.0, 1.0, 10.0)
    assert "median 2600 ms, p99 4800 ms" in slow and slow.endswith("this machine is too slow for --rate 10; try a "
                                                                   "lower one")
    assert command_age_text(None, None, 1.0) == "command age: no command yet"


def _counter_names_in_the_code() -> set[str]:
    """Every counter name the daemon's code increments literally, read from its source."""
    names = set()
    patterns = [r"counters\[\"([a-z_.]+)\"\]", r"_count\(\"([a-z_.]+)\"", r"counter: ClassVar\[str\] = \"([a-z_]+)\""]
    for path in [*(ROOT / "gcs" / "daemon").glob("*.py"), *(ROOT / "gcs" / "engine").glob("*.py"),
                 *(ROOT / "gcs" / "adapters").glob("mavlink_*.py")]:
        text = path.read_text()
        prefix = "mavlink." if path.name.startswith("mavlink_") else ""
        names |= {prefix + name for pattern in patterns for name in re.findall(pattern, text)}
    return names


def test_every_counter_the_daemon_counts_is_explained_in_the_help_and_in_docs_cli() -> None:
    names = _counter_names_in_the_code() | {f"rejected.{reason}" for reason in REJECTIONS} | {
        "plans_superseded", "planner_restarts", "mavlink.gcs_heartbeats", "accepted.report", "accepted.nav",
        "accepted.truth", "accepted.unlisted.report", "mavlink.ack_accepted", "mavlink.ack_denied"}
    # the live map's own counters (on its page, docs/live_map.md), not the daemon status's
    names = {name for name in names if name != "errors.live_map" and not name.startswith("picture.")}
    assert len(names) > 50
    assert [name for name in sorted(names) if counter_meaning(name) is None] == []
    docs = (ROOT / "docs" / "cli.md").read_text()
    listed = [*COUNTERS, *(f"{prefix}*" for prefix in COUNTER_FAMILIES), *(f"rejected.{r}" for r in REJECTIONS)]
    assert [name for name in listed if f"`{name}`" not in docs] == []


def test_the_protocol_errors_reasons_are_rejections_the_text_explains() -> None:
    from protocols.errors import REJECT_REASONS

    assert REJECT_REASONS <= set(REJECTIONS)


def _status(tracks: int = 1) -> DaemonStatus:
    vehicles = tuple(VehicleStatus(vehicle_id=f"uav{i}", sysid=i, link="ok" if i < 3 else "lost",
                                   last_report_stamp_ns=NOW - 2 * S, reports=30, heartbeat="ok", liveliness="ok",
                                   control="daemon" if i == 1 else "pilot") for i in (1, 2, 3))
    return DaemonStatus(stamp_ns=NOW, uptime_s=40.0, scenario="wang2012_urban", vehicles=vehicles,
                        counters={"decisions": 25, "rejected.late": 2, "rejected.stale": 1, "accepted.report": 90},
                        last_track_stamp_ns=NOW - S, command_age_ms_median=700.0, command_age_ms_p99=1300.0,
                        tracks=tuple(TrackSummary(target_id=f"car{k}", stamp_ns=NOW - S, x_m=1.0, y_m=2.0,
                                                  position_std_m=7.4, contributing_vehicles=("uav1",))
                                     for k in range(tracks)))


def test_the_status_shows_times_not_nanoseconds() -> None:
    text = "\n".join(format_status(_status(), step_s=1.0))
    assert "status at 2023-11-14T22:13:20Z, last track 2023-11-14T22:13:19Z, 1 s ago" in text
    assert "reports     30, last 2023-11-14T22:13:18Z, 2 s ago" in text
    assert "the loop keeps up" in text and not re.search(r"\d{19}", text)


def test_gcs_run_logs_a_line_every_30_s_of_flight_and_says_what_it_did_when_it_stops(caplog) -> None:
    report = FlightReport(lambda: _status(tracks=5), step_s=1.0)
    with caplog.at_level(logging.INFO, logger="gcs.daemon.flight_report"):
        for k in range(75):  # 75 decision steps, one a second of the vehicles' clock; the target seen in 2 of 3
            report(StepRecord(k, 1000 * S + k * S, {"uav1": k % 3 != 0, "uav2": False}, None, None, ("uav1",), 0))
    lines = [r.getMessage() for r in caplog.records]
    assert [line.split(":")[0] for line in lines] == ["flown 30 s", "flown 60 s"]
    assert lines[0] == ("flown 30 s: vehicles 2/3 linked, 1 steered; steps 31, target seen in 20/31; plans 25; "
                        "tracks: car0 1-sigma 7 m, car1 1-sigma 7 m, car2 1-sigma 7 m and 2 more; command age "
                        "median/p99 0.7/1.3 s ok; rejected 3")
    stopped = report.stopped({"decisions": 0, "steps_without_vehicles": 75}, mavlink=False)
    assert stopped == ("daemon stopped: 75 decision steps fused over 74 s of flight, the target seen in 50; 0 plans "
                       "made (75 steps had no vehicle alive to plan for); MAVLink off: plans published over Zenoh, "
                       "no vehicle commanded")
    assert FlightReport(_status, 1.0).stopped({"mavlink.heading_commands": 4, "mavlink.carrots": 2}, True) == (
        "daemon stopped: no decision step (no vehicle report came in); 6 steering commands sent over MAVLink")
