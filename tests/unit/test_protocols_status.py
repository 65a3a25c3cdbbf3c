"""``DaemonStatus`` version 4 and its tracks; version 3 still decodes (no network)."""

from __future__ import annotations

import json

import msgspec
import pytest

from protocols import DaemonStatus, ProtocolError, TrackSummary, VehicleStatus, decode, encode, json_schema
from protocols.legacy import DaemonStatusV3

V3_ENCODING = "application/json;gcs.DaemonStatus/3"
V4_ENCODING = "application/json;gcs.DaemonStatus/4"
VEHICLE = VehicleStatus(vehicle_id="uav1", sysid=1, link="ok", last_report_stamp_ns=9, reports=4,
                        heartbeat="ok", liveliness="ok", control="daemon")
TRACK = {"target_id": "t1", "stamp_ns": 7_000_000_000, "x_m": 1200.25, "y_m": -40.5, "position_std_m": 3.0,
         "speed_mps": 12.5, "contributing_vehicles": ["uav1", "uav2"]}


def _v3_payload() -> bytes:
    return json.dumps({"stamp_ns": 8_000_000_000, "uptime_s": 12.5, "scenario": "city",
                       "vehicles": [msgspec.to_builtins(VEHICLE)], "counters": {"accepted.report": 4},
                       "last_track_stamp_ns": 7_000_000_000, "command_age_ms_median": 812.4,
                       "command_age_ms_p99": 1930.0}).encode()


def _status(tracks: list[dict]) -> bytes:
    return json.dumps({"stamp_ns": 1, "uptime_s": 0.0, "scenario": "city", "vehicles": [], "tracks": tracks}).encode()


def test_a_v3_status_decodes_to_a_v4_status_without_tracks() -> None:
    old = msgspec.json.decode(_v3_payload())
    for encoding in (V3_ENCODING, None):  # without an encoding it is a valid version 4 as it is
        new = decode(_v3_payload(), encoding, DaemonStatus)
        assert type(new) is DaemonStatus and new.tracks == ()
        assert {k: v for k, v in json.loads(encode(new)[0]).items() if k != "tracks"} == old
        assert new.vehicles == (VEHICLE,)
        assert encode(new)[1] == V4_ENCODING  # always written as the current version


def test_a_v3_encoding_refuses_tracks_and_judges_by_the_v3_rules() -> None:
    with pytest.raises(ProtocolError, match="unknown field `tracks`") as info:
        decode(_status([TRACK]), V3_ENCODING, DaemonStatus)
    assert "DaemonStatus/3" in info.value.message and info.value.field == "$.tracks"
    bad = json.loads(_v3_payload())
    bad["uptime_s"] = -1.0
    with pytest.raises(ProtocolError, match="DaemonStatus/3") as info:
        decode(json.dumps(bad).encode(), V3_ENCODING, DaemonStatus)
    assert info.value.field == "$.uptime_s"
    with pytest.raises(ProtocolError, match="reads 3, 4") as info:
        decode(_v3_payload(), "application/json;gcs.DaemonStatus/2", DaemonStatus)
    assert info.value.reason == "encoding"


def test_v3_has_the_v4_fields_but_tracks() -> None:
    assert set(DaemonStatus.__struct_fields__) - set(DaemonStatusV3.__struct_fields__) == {"tracks"}
    assert set(DaemonStatusV3.__struct_fields__) <= set(DaemonStatus.__struct_fields__)
    old = json.loads(json_schema(DaemonStatus, 3))["$defs"]["DaemonStatusV3"]
    assert "tracks" not in old["properties"] and "command_age_ms_p99" in old["properties"]


def test_a_v4_status_round_trips_with_its_tracks() -> None:
    tracks = (TrackSummary(**{**TRACK, "contributing_vehicles": ("uav1", "uav2")}),
              TrackSummary(target_id="t2", stamp_ns=7_000_000_000, x_m=0.0, y_m=0.0, position_std_m=0.0,
                           speed_mps=None, contributing_vehicles=()))
    status = DaemonStatus(stamp_ns=8_000_000_000, uptime_s=12.5, scenario="city", vehicles=(VEHICLE,),
                          last_track_stamp_ns=7_000_000_000, tracks=tracks)
    payload, encoding = encode(status)
    assert encoding == V4_ENCODING
    back = decode(payload, encoding, DaemonStatus)
    assert back == status and back.tracks[0].contributing_vehicles == ("uav1", "uav2")
    assert back.tracks[1].speed_mps is None and back.tracks[1].position_std_m == 0.0
    assert json.loads(payload)["tracks"][0] == TRACK


@pytest.mark.parametrize(("field", "value", "path"), [
    ("position_std_m", -0.5, "$.tracks[0].position_std_m"),
    ("target_id", "t 1", "$.tracks[0].target_id"),
    ("target_id", "", "$.tracks[0].target_id"),
    ("speed_mps", -1.0, "$.tracks[0].speed_mps"),
    ("x_m", 2e8, "$.tracks[0].x_m"),
    ("contributing_vehicles", ["uav/1"], "$.tracks[0].contributing_vehicles[0]"),
])
def test_an_invalid_track_summary_is_rejected_naming_its_field(field: str, value: object, path: str) -> None:
    with pytest.raises(ProtocolError) as info:
        decode(_status([{**TRACK, field: value}]), V4_ENCODING, DaemonStatus)
    assert info.value.field == path and info.value.reason == "invalid"
    with pytest.raises(ProtocolError) as info:
        encode(DaemonStatus(stamp_ns=1, uptime_s=0.0, scenario="city", vehicles=(),
                            tracks=(TrackSummary(**{**TRACK, field: value}),)))
    assert info.value.field == path


def test_a_track_summary_needs_its_contributing_vehicles_and_no_more() -> None:
    with pytest.raises(ProtocolError, match="contributing_vehicles"):
        decode(_status([{k: v for k, v in TRACK.items() if k != "contributing_vehicles"}]), V4_ENCODING)
    with pytest.raises(ProtocolError, match="unknown field `model`"):
        decode(_status([{**TRACK, "model": "cv2d"}]), V4_ENCODING)
    assert decode(_status([{k: v for k, v in TRACK.items() if k != "speed_mps"}]), V4_ENCODING).tracks[0].speed_mps \
        is None
