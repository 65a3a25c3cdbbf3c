"""Message types: cross-field rules on construction, Struct config, versions, schema, purity."""

from __future__ import annotations

import ast
import json
import math
import sys
from pathlib import Path

import msgspec
import pytest

from protocols import (
    MAX_DETECTIONS,
    MESSAGE_TYPES,
    REJECT_REASONS,
    TRACK_MODEL_DIMS,
    DaemonStatus,
    GpsFix,
    InsIncrement,
    Measurement,
    NavReport,
    PlanCommand,
    PredictedPoint,
    ProtocolError,
    SensorReport,
    TrackEstimate,
    VehicleStatus,
    encode,
    encoding_for,
    json_schema,
)
from protocols.legacy import SensorReportV1

PROTOCOLS = Path(__file__).resolve().parents[2] / "protocols"
BASE = dict(vehicle_id="uav1", seq=0, stamp_ns=0, vehicle_position_enu_m=(0.0, 0.0, 100.0))
EYE4 = (1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0)


def track(**changes: object) -> TrackEstimate:
    fields: dict[str, object] = dict(
        target_id="t", seq=0, stamp_ns=0, model="cv2d", state=(0.0, 0.0, 1.0, 1.0),
        covariance=EYE4, contributing_vehicles=("uav1",),
    )
    fields.update(changes)
    return TrackEstimate(**fields)  # type: ignore[arg-type]


# ---------------------------------------------------------------- SensorReport rules
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(detected=True), "$.azimuth_rad"),
        (dict(detected=True, range_m=10.0, range_std_m=1.0), "$.azimuth_rad"),
        (dict(detected=True, azimuth_rad=0.1), "$.azimuth_std_rad"),
        (dict(detected=True, azimuth_rad=0.1, azimuth_std_rad=0.01, range_std_m=1.0), "$.range_std_m"),
        (
            dict(detected=True, azimuth_rad=0.1, azimuth_std_rad=0.01, elevation_rad=-0.2),
            "$.elevation_std_rad",
        ),
        (dict(detected=False, azimuth_rad=0.1, azimuth_std_rad=0.01), "$.azimuth_rad"),
        (dict(detected=False, range_m=5.0, range_std_m=1.0), "$.range_m"),
        (dict(detected=False, elevation_std_rad=0.1), "$.elevation_std_rad"),
    ],
)
def test_sensor_report_v1_keeps_its_cross_field_rules(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ProtocolError) as info:
        SensorReportV1(**BASE, **kwargs)  # type: ignore[arg-type]
    assert info.value.field == field
    assert field.removeprefix("$.") in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(range_m=10.0), "$.range_std_m"),
        (dict(range_std_m=1.0), "$.range_std_m"),
        (dict(elevation_rad=-0.2), "$.elevation_std_rad"),
        (dict(elevation_std_rad=0.1), "$.elevation_std_rad"),
    ],
)
def test_a_measurement_pairs_every_value_with_its_std(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ProtocolError) as info:
        Measurement(azimuth_rad=0.1, azimuth_std_rad=0.01, **kwargs)  # type: ignore[arg-type]
    assert info.value.field == field
    assert field.removeprefix("$.") in str(info.value)


def test_a_measurement_needs_an_azimuth() -> None:
    with pytest.raises(TypeError, match="azimuth_rad"):
        Measurement(range_m=10.0, range_std_m=1.0, azimuth_std_rad=0.01)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="azimuth_std_rad"):
        Measurement(azimuth_rad=0.1)  # type: ignore[call-arg]


def test_sensor_report_valid_shapes() -> None:
    bearing_only = SensorReport(**BASE, detections=(Measurement(azimuth_rad=-0.5, azimuth_std_rad=0.02),))
    assert bearing_only.detections[0].range_m is None and bearing_only.detected
    full = Measurement(range_m=300.0, range_std_m=3.0, azimuth_rad=math.pi, azimuth_std_rad=0.01,
                       elevation_rad=-0.4, elevation_std_rad=0.01)
    several = SensorReport(**BASE, detections=(full, full))
    assert several.detections[1].elevation_rad == -0.4 and len(several.detections) == 2
    missed = SensorReport(**BASE)
    assert missed.detections == () and not missed.detected


def test_a_report_carries_at_most_max_detections() -> None:
    one = Measurement(azimuth_rad=0.1, azimuth_std_rad=0.01)
    assert len(SensorReport(**BASE, detections=(one,) * MAX_DETECTIONS).detections) == MAX_DETECTIONS
    with pytest.raises(ProtocolError, match=f"at most {MAX_DETECTIONS}") as info:
        SensorReport(**BASE, detections=(one,) * (MAX_DETECTIONS + 1))
    assert info.value.field == "$.detections"


def test_azimuth_minus_pi_is_accepted_on_the_wire() -> None:
    # atan2(-0.0, -1.0) == -pi: the same direction as pi, so producers need not special-case it.
    msg = SensorReport(**BASE, detections=(Measurement(azimuth_rad=math.atan2(-0.0, -1.0), azimuth_std_rad=0.1),))
    assert msg.detections[0].azimuth_rad == -math.pi
    assert encode(msg)[1] == encoding_for(SensorReport) == "application/json;gcs.SensorReport/2"


# ---------------------------------------------------------------- NavReport, covariances
def test_nav_report_needs_a_source() -> None:
    with pytest.raises(ProtocolError, match="gps, ins, velocity_enu_mps") as info:
        NavReport(vehicle_id="uav1", seq=0, stamp_ns=0, heading_rad=0.0)
    assert info.value.field == "$.gps"
    ins = InsIncrement(dt_s=0.1, distance_m=2.0, heading_change_rad=0.01)
    assert NavReport(vehicle_id="uav1", seq=0, stamp_ns=0, ins=ins).ins == ins
    fix = GpsFix(lat_deg=47.0, lon_deg=8.0, alt_m=500.0, fix_type=3, h_acc_m=2.0, v_acc_m=3.0)
    assert NavReport(vehicle_id="uav1", seq=0, stamp_ns=0, gps=fix).gps is fix


@pytest.mark.parametrize(
    ("cov", "field", "words"),
    [
        ((1.0, 0.5, 0.4, 1.0), "$.position_cov_m2[1]", "not symmetric"),
        ((-1.0, 0.0, 0.0, 1.0), "$.position_cov_m2[0]", "negative"),
        ((1.0, 0.0, 0.0, math.nan), "$.position_cov_m2[3]", "not finite"),
    ],
)
def test_predicted_point_covariance_rules(cov: tuple[float, ...], field: str, words: str) -> None:
    with pytest.raises(ProtocolError, match=words) as info:
        PredictedPoint(stamp_ns=0, position_enu_m=(0.0, 0.0), position_cov_m2=cov)
    assert info.value.field == field


def test_covariance_symmetry_tolerance_is_relative() -> None:
    p = PredictedPoint(stamp_ns=0, position_enu_m=(0, 0), position_cov_m2=(1e6, 3.0, 3.0 + 1e-4, 1e6))
    assert p.position_cov_m2[2] == 3.0001  # 1e-4 off on a 1e6 scale is round-off, accepted
    with pytest.raises(ProtocolError):
        PredictedPoint(stamp_ns=0, position_enu_m=(0, 0), position_cov_m2=(1.0, 3.0, 3.001, 1.0))


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        (dict(state=(0.0, 0.0, 1.0)), "$.state"),  # cv2d needs 4
        (dict(model="ca2d"), "$.state"),  # ca2d needs 6
        (dict(covariance=EYE4[:-1]), "$.covariance"),
        (dict(covariance=(1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, -1.0, 0, 0, 0, 0, 1.0)), "$.covariance[10]"),
        (dict(covariance=(1.0, 2.0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0)), "$.covariance[1]"),
    ],
)
def test_track_estimate_rules(changes: dict[str, object], field: str) -> None:
    with pytest.raises(ProtocolError) as info:
        track(**changes)
    assert info.value.field == field


def test_track_estimate_models() -> None:
    assert TRACK_MODEL_DIMS == {"cv2d": 4, "ca2d": 6}
    custom = track(model="ct2d", state=(0.0, 0.0, 1.0, 1.0, 0.1), covariance=tuple(
        1.0 if i % 6 == 0 else 0.0 for i in range(25)))
    assert len(custom.covariance) == 25


# ---------------------------------------------------------------- struct config and versions
@pytest.mark.parametrize("tp", MESSAGE_TYPES, ids=lambda tp: tp.__name__)
def test_struct_config(tp: type[msgspec.Struct]) -> None:
    config = tp.__struct_config__
    assert config.frozen and config.forbid_unknown_fields
    # DaemonStatus 2: heartbeat, liveliness and control; 3: command age; 4: tracks. SensorReport 2: detections.
    version = {DaemonStatus: 4, SensorReport: 2}.get(tp, 1)
    assert tp.VERSION == version  # type: ignore[attr-defined]
    assert "VERSION" not in tp.__struct_fields__
    with pytest.raises(TypeError, match="positional"):
        tp(1)  # keyword-only: positional arguments are refused
    assert encoding_for(tp) == f"application/json;gcs.{tp.__name__}/{version}"


def test_messages_are_immutable_and_version_is_not_on_the_wire() -> None:
    msg = SensorReport(**BASE)
    with pytest.raises(AttributeError):
        msg.seq = 2  # type: ignore[misc]
    assert "VERSION" not in json.loads(encode(msg)[0])


def test_daemon_status_defaults_and_literals() -> None:
    status = DaemonStatus(stamp_ns=1, uptime_s=0.0, scenario="city", vehicles=())
    assert status.counters == {} and status.last_track_stamp_ns is None and status.tracks == ()
    vs = VehicleStatus(vehicle_id="uav1", link="lost", reports=3)
    assert vs.sysid is None and vs.autopilot is None
    assert PlanCommand.__struct_fields__[-1] == "planner"


# ---------------------------------------------------------------- JSON Schema
@pytest.mark.parametrize("tp", MESSAGE_TYPES, ids=lambda tp: tp.__name__)
def test_json_schema(tp: type[msgspec.Struct]) -> None:
    schema = json.loads(json_schema(tp))
    body = schema["$defs"][tp.__name__]
    assert body["additionalProperties"] is False
    assert set(body["properties"]) == set(tp.__struct_fields__)


def test_json_schema_carries_bounds_and_patterns() -> None:
    props = json.loads(json_schema(SensorReport))["$defs"]["SensorReport"]["properties"]
    assert props["vehicle_id"]["pattern"].startswith("^[A-Za-z0-9_-]{1,64}$")
    assert props["seq"]["minimum"] == 0
    assert props["vehicle_position_enu_m"]["prefixItems"][0]["maximum"] == 1e8
    assert props["detections"]["maxItems"] == MAX_DETECTIONS
    measurement = json.loads(json_schema(SensorReport))["$defs"]["Measurement"]
    assert set(measurement["required"]) == {"azimuth_rad", "azimuth_std_rad"}


def test_json_schema_of_the_earlier_version_is_its_own() -> None:
    old = json.loads(json_schema(SensorReport, 1))["$defs"]["SensorReportV1"]
    assert {"detected", "range_m", "target_id"} <= set(old["properties"])
    assert "detections" not in old["properties"]


# ---------------------------------------------------------------- errors and purity
def test_protocol_error() -> None:
    err = ProtocolError("range_m out of range", field="$.range_m", reason="invalid")
    assert isinstance(err, ValueError)
    assert (err.field, err.reason, err.message) == ("$.range_m", "invalid", "range_m out of range")
    assert "field='$.range_m'" in repr(err)
    assert {"invalid", "malformed", "oversize", "encoding", "unexpected_type", "key"} == REJECT_REASONS
    with pytest.raises(ValueError, match="unknown ProtocolError reason"):
        ProtocolError("x", reason="bogus")


def imported_top_level_modules(path: Path) -> set[str]:
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level:
            found.add((node.module or "").split(".")[0])
    return found


def test_protocols_imports_only_stdlib_and_msgspec() -> None:
    files = sorted(PROTOCOLS.glob("*.py"))
    assert {f.name for f in files} >= {"__init__.py", "codec.py", "errors.py", "keys.py", "messages.py"}
    forbidden_stdlib = {"os", "io", "socket", "time", "pathlib", "subprocess", "threading", "random"}
    for path in files:
        for module in imported_top_level_modules(path):
            allowed = module in {"msgspec", "protocols"} or module in sys.stdlib_module_names
            assert allowed, (path, module)
            assert module not in forbidden_stdlib, (path, module)
