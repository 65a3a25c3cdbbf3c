"""``gcs status``'s lines for the daemon's tracks (no network)."""

from __future__ import annotations

from gcs.daemon.status_cli import format_status
from protocols.messages import DaemonStatus, TrackSummary, VehicleStatus

VEHICLES = (VehicleStatus(vehicle_id="uav1", link="ok", reports=12), VehicleStatus(vehicle_id="uav2", link="lost",
                                                                                   reports=3))
TRACKS = (
    TrackSummary(target_id="t1", stamp_ns=7_000_000_000, x_m=1200.34, y_m=-40.5, position_std_m=3.04,
                 speed_mps=12.46, contributing_vehicles=("uav1", "uav2")),
    TrackSummary(target_id="t2", stamp_ns=6_000_000_000, x_m=-5.0, y_m=310.0, position_std_m=0.0, speed_mps=None,
                 contributing_vehicles=()),
)


def _status(tracks: tuple[TrackSummary, ...]) -> DaemonStatus:
    return DaemonStatus(stamp_ns=8_000_000_000, uptime_s=20.0, scenario="city", vehicles=VEHICLES,
                        counters={"accepted.report": 15}, last_track_stamp_ns=7_000_000_000, tracks=tracks)


def test_one_line_per_track_after_the_vehicles_and_before_the_counters() -> None:
    lines = format_status(_status(TRACKS))
    track_lines = [line for line in lines if line.startswith("  track ")]
    assert len(track_lines) == 2
    t1, t2 = track_lines
    assert t1.split()[:2] == ["track", "t1"]
    assert "at (1200.3, -40.5) m" in t1
    assert "1-sigma 3.0 m" in t1 and "speed 12.5 m/s" in t1 and "1970-01-01T00:00:07Z, 1 s ago" in t1  # at the status
    assert t1.endswith("vehicles uav1, uav2")
    assert t2.split()[:2] == ["track", "t2"]
    assert "at (-5.0, 310.0) m" in t2 and "1-sigma 0.0 m" in t2 and "speed -" in t2 and t2.endswith("vehicles -")
    vehicle_rows = [i for i, line in enumerate(lines) if line.split()[0] in ("uav1", "uav2")]
    counter_row = next(i for i, line in enumerate(lines) if "accepted.report" in line)
    first, last = lines.index(t1), lines.index(t2)
    assert max(vehicle_rows) < first < last < counter_row
    assert "no tracks" not in lines[first - 1:counter_row]


def test_a_status_without_tracks_says_so() -> None:
    lines = format_status(_status(()))
    assert "  no tracks" in lines and not any(line.startswith("  track ") for line in lines)
    assert lines.index("  no tracks") < next(i for i, line in enumerate(lines) if "accepted.report" in line)
