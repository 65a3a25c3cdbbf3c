"""Default single-target scenarios: the simulator's reports, random streams and replayed tracks are those of
the single-measurement wire (``SensorReport/1``), bit for bit.

``data/single_target_golden.json`` holds what the simulator and ``gcs replay --process`` produced before
reports carried a list of detections (seed 11 reports of three shipped scenarios; seed 4, 30 s of
wang2012_urban processed): every figure here is compared with those recorded values, not with this build.
"""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import pytest

from gcs.adapters.recording import Recorder, read_recording
from gcs.bench.replay import make_recording
from gcs.config.world import build_world
from gcs.recordings.replay import process
from gcs.scenarios import load_scenario
from protocols.codec import decode
from protocols.legacy import SensorReportV1
from protocols.messages import SensorReport
from sim_vehicles.scene import Scene

GOLDEN = json.loads((Path(__file__).parent / "data" / "single_target_golden.json").read_text())
V1_ENCODING = "application/json;gcs.SensorReport/1"


def _as_v1_row(report: SensorReport) -> list:
    """The fields a version-1 report had, from a version-2 one of at most one detection."""
    assert len(report.detections) <= 1
    d = report.detections[0] if report.detections else None
    values = [None] * 6 if d is None else [d.range_m, d.azimuth_rad, d.elevation_rad,
                                           d.range_std_m, d.azimuth_std_rad, d.elevation_std_rad]
    return [report.vehicle_id, report.stamp_ns, report.detected, *values, list(report.vehicle_position_enu_m)]


@pytest.mark.parametrize("name", ["wang2012_urban", "zuo2021_aoa", "downtown_dense"])
def test_default_scenarios_report_what_they_reported_before(name: str) -> None:
    scenario = load_scenario(name)
    scene = Scene(scenario, build_world(scenario), seed=11, epoch_ns=0)
    rows = []
    for _ in range(12):
        for _ in range(20):
            scene.advance(0.05, {})
        rows += [_as_v1_row(scene.sensor_report(v)) for v in scene.vehicles]
    assert rows == GOLDEN[name]["reports"]
    assert [t.target_id for t in scene.truths()] == [scenario.target.id]
    assert list(scene.target.position) == GOLDEN[name]["truth"]


def _v1_copy(source: Path, target: Path) -> int:
    """The recording with every report rewritten as the version-1 payload of the same measurement; how many."""
    rewritten = 0
    with Recorder(target) as recorder:
        for r in read_recording(source):
            payload, encoding = r.payload, r.encoding
            if encoding.startswith("application/json;gcs.SensorReport/"):
                report = decode(payload, encoding, SensorReport)
                d = report.detections[0] if report.detections else None
                fields = {} if d is None else {k: getattr(d, k) for k in d.__struct_fields__}
                old = SensorReportV1(vehicle_id=report.vehicle_id, seq=report.seq, stamp_ns=report.stamp_ns,
                                     vehicle_position_enu_m=report.vehicle_position_enu_m,
                                     vehicle_position_std_m=report.vehicle_position_std_m,
                                     detected=d is not None, **fields)
                payload, encoding = msgspec.json.encode(old), V1_ENCODING
                rewritten += 1
            recorder.write(r.key, payload, encoding, r.log_time_ns)
    return rewritten


def test_recorded_v1_streams_replay_to_the_tracks_they_gave(tmp_path: Path) -> None:
    scenario = load_scenario("wang2012_urban")
    inputs, old = tmp_path / "in.mcap", tmp_path / "v1.mcap"
    make_recording(scenario, build_world(scenario), inputs, duration_s=30.0, seed=4)
    assert _v1_copy(inputs, old) == 90  # 3 vehicles, one report a second for 30 s
    assert {r.encoding for r in read_recording(old) if r.key.endswith("/report")} == {V1_ENCODING}
    golden = GOLDEN["replay"]
    for path in (inputs, old):
        tracks, _, counters = process(path, scenario)
        assert len(tracks) == golden["count"]
        last = tracks[-1]
        assert [last.stamp_ns, list(last.state), list(last.covariance)] == golden["last"]
        assert not any(name.startswith("rejected") for name in counters)
