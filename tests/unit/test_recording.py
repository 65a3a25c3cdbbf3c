"""MCAP recordings: exact bytes and times, recovery of a killed writer, clear errors, replay processing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest
from mcap.writer import Writer

from gcs.adapters.recording import LIVELINESS_ENCODING, Recorder, RecordingError, read_recording
from gcs.recordings.replay import process, summarise
from gcs.scenarios import load_scenario
from protocols.codec import encode, json_schema
from protocols.keys import report_key
from protocols.messages import SensorReport

S = 1_000_000_000


def _report(seq: int, vehicle: str = "uav1") -> SensorReport:
    return SensorReport(vehicle_id=vehicle, seq=seq, stamp_ns=seq * S, vehicle_position_enu_m=(1.0, 2.0, 200.0))


def test_round_trip_keeps_bytes_times_channels_and_order(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    written = []
    with Recorder(path) as recorder:
        recorder.write_liveliness("gcs/vehicle/uav1/alive", True, 5)
        for seq in range(1, 301):
            payload, encoding = encode(_report(seq, "uav1" if seq % 2 else "uav2"))
            key = report_key("uav1" if seq % 2 else "uav2")
            recorder.write(key, payload, encoding, 10 * seq)
            written.append((key, payload, encoding, 10 * seq, seq * S))
        recorder.write("gcs/vehicle/uav1/report", b"\\x00garbage", "text/plain", 99_999)
    records = list(read_recording(path))
    assert records[0].encoding == LIVELINESS_ENCODING and records[0].payload == b"alive"
    assert [(r.key, r.payload, r.encoding, r.log_time_ns, r.publish_time_ns) for r in records[1:-1]] == written
    assert records[-1].payload == b"\\x00garbage" and records[-1].publish_time_ns == 99_999  # no stamp: receive time
    info = summarise(path)
    assert info["messages"] == 302 and info["vehicles"] == ["uav1", "uav2"]
    assert {c["key"] for c in info["channels"]} == {"gcs/vehicle/uav1/alive", report_key("uav1"), report_key("uav2")}


def test_a_truncated_recording_is_recovered_up_to_its_last_chunk_with_a_warning(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    with Recorder(path) as recorder:
        for seq in range(1, 5001):
            recorder.write(report_key("uav1"), *encode(_report(seq)), seq)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    warnings: list[str] = []
    recovered = list(read_recording(cut, warn=warnings.append))
    assert 0 < len(recovered) < 5000
    assert [r.publish_time_ns for r in recovered] == [seq * S for seq in range(1, len(recovered) + 1)]
    assert len(warnings) == 1 and "without a summary" in warnings[0] and "recovered" in warnings[0]


def test_a_killed_writer_leaves_a_readable_file(tmp_path) -> None:
    path = tmp_path / "killed.mcap"
    program = textwrap.dedent(f"""
        import os, signal
        from gcs.adapters.recording import Recorder
        from protocols.codec import encode
        from protocols.messages import SensorReport
        recorder = Recorder({str(path)!r})
        for seq in range(1, 20001):
            report = SensorReport(vehicle_id="uav1", seq=seq, stamp_ns=seq, vehicle_position_enu_m=(1.0, 2.0, 3.0))
            recorder.write("gcs/vehicle/uav1/report", *encode(report), seq)
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    done = subprocess.run([sys.executable, "-c", program], timeout=120)
    assert done.returncode == -signal.SIGKILL
    warnings: list[str] = []
    recovered = list(read_recording(path, warn=warnings.append))
    assert len(recovered) > 10_000 and warnings  # every flushed chunk, and a warning that the end is missing


def test_corruption_is_an_error_naming_the_offset(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    with Recorder(path) as recorder:
        for seq in range(1, 3001):
            recorder.write(report_key("uav1"), *encode(_report(seq)), seq)
    data = bytearray(path.read_bytes())
    inside = data.index(b"zstd", len(data) // 3) + 100  # in the compressed data of a chunk
    data[inside: inside + 64] = bytes(64)
    path.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match=r"byte offset \d+"):
        list(read_recording(path))


def test_an_unknown_schema_version_is_an_error_naming_the_channel(tmp_path) -> None:
    path = tmp_path / "future.mcap"
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema("gcs.SensorReport/9", "jsonschema", json_schema(SensorReport))
        channel = writer.register_channel("gcs/vehicle/uav1/report", "json", schema,
                                          metadata={"zenoh_encoding": "application/json;gcs.SensorReport/9"})
        writer.add_message(channel, log_time=1, data=b"{}", publish_time=1)
        writer.finish()
    with pytest.raises(RecordingError, match=r"channel 'gcs/vehicle/uav1/report' \(id \d+\) at byte offset \d+"):
        list(read_recording(path))


def test_processing_counts_what_it_rejects_and_skips_nothing_silently(tmp_path) -> None:
    path = tmp_path / "r.mcap"
    scenario = load_scenario("wang2012_urban")
    with Recorder(path) as recorder:
        for seq in range(1, 11):
            for vehicle in ("uav1", "uav2", "uav3"):
                recorder.write(report_key(vehicle), *encode(_report(seq, vehicle)), seq * S)
        recorder.write(report_key("uav1"), b"not json", "application/json;gcs.SensorReport/1", 11 * S)
        recorder.write(report_key("intruder"), *encode(_report(12, "intruder")), 12 * S)
    tracks, plans, counters = process(path, scenario)
    assert tracks == [] and plans == []  # nothing detected: no track
    assert counters["accepted.report"] == 30
    assert counters["rejected.malformed"] == 1 and counters["rejected.unknown_vehicle"] == 1
    assert os.path.getsize(path) > 0
