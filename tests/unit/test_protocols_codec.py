"""Codec properties: round trips of valid messages; fuzzing (nothing but ProtocolError escapes).

The strategies generate only valid messages. Specific rejections and their messages are in
``test_protocols_codec_errors.py``.
"""

from __future__ import annotations

import json
import math

import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from protocols import (
    MAX_PAYLOAD_BYTES,
    MESSAGE_TYPES,
    DaemonStatus,
    FederatedTrack,
    MemberTracks,
    TargetTruth,
    GpsFix,
    InsIncrement,
    Measurement,
    NavReport,
    PlanCommand,
    PredictedPoint,
    ProtocolError,
    SensorReport,
    TrackEstimate,
    TrackSummary,
    VehicleScenario,
    VehicleStatus,
    decode,
    encode,
    encoding_for,
)
from protocols.legacy import LEGACY_VERSIONS, SensorReportV1

PI = math.pi
INT64_MAX = 2**63 - 1


# ---------------------------------------------------------------- strategies (valid only)
def floats(lo: float, hi: float, **kw: bool) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, **kw)


ids = st.from_regex(r"[A-Za-z0-9_-]{1,64}", fullmatch=True)
stamps = st.integers(0, INT64_MAX)
positions = floats(-1e8, 1e8)
pos3 = st.tuples(positions, positions, positions)
std_m = floats(0.0, 1e8, exclude_min=True)
std_rad = floats(0.0, 2 * PI, exclude_min=True)
angles = floats(-PI, PI)
rates = floats(-2 * PI, 2 * PI)
altitudes = floats(-1e4, 1e5)
texts = st.text(max_size=40)


@st.composite
def measurement_fields(draw: st.DrawFn) -> dict[str, float]:
    """The measurement fields of one detection (azimuth always; range and elevation maybe)."""
    meas: dict[str, float] = dict(azimuth_rad=draw(angles), azimuth_std_rad=draw(std_rad))
    if draw(st.booleans()):
        meas.update(range_m=draw(floats(0.0, 1e8)), range_std_m=draw(std_m))
    if draw(st.booleans()):
        meas.update(elevation_rad=draw(floats(-PI / 2, PI / 2)), elevation_std_rad=draw(std_rad))
    return meas


measurements = measurement_fields().map(lambda fields: Measurement(**fields))


@st.composite
def sensor_reports(draw: st.DrawFn) -> SensorReport:
    return SensorReport(
        vehicle_id=draw(ids),
        seq=draw(stamps),
        stamp_ns=draw(stamps),
        vehicle_position_enu_m=draw(pos3),
        vehicle_position_std_m=draw(st.none() | std_m),
        detections=tuple(draw(st.lists(measurements, max_size=6))),
    )


@st.composite
def sensor_reports_v1(draw: st.DrawFn) -> SensorReportV1:
    detected = draw(st.booleans())
    return SensorReportV1(
        vehicle_id=draw(ids),
        seq=draw(stamps),
        stamp_ns=draw(stamps),
        target_id=draw(ids),
        vehicle_position_enu_m=draw(pos3),
        vehicle_position_std_m=draw(st.none() | std_m),
        detected=detected,
        **(draw(measurement_fields()) if detected else {}),
    )


gps_fixes = st.builds(
    GpsFix,
    lat_deg=floats(-90, 90),
    lon_deg=floats(-180, 180),
    alt_m=altitudes,
    fix_type=st.integers(0, 8),
    h_acc_m=std_m,
    v_acc_m=std_m,
    satellites=st.none() | st.integers(0, 255),
)
ins_increments = st.builds(
    InsIncrement,
    dt_s=floats(0.0, 3600.0, exclude_min=True),
    distance_m=floats(0.0, 1e8),
    heading_change_rad=rates,
)
velocities = floats(-1e4, 1e4)


@st.composite
def nav_reports(draw: st.DrawFn) -> NavReport:
    present = draw(st.sets(st.sampled_from(["gps", "ins", "vel"]), min_size=1))
    vel3 = st.tuples(velocities, velocities, velocities)
    return NavReport(
        vehicle_id=draw(ids),
        seq=draw(stamps),
        stamp_ns=draw(stamps),
        gps=draw(gps_fixes) if "gps" in present else None,
        ins=draw(ins_increments) if "ins" in present else None,
        velocity_enu_mps=draw(vel3 if "vel" in present else st.none()),
        turn_rate_rad_s=draw(st.none() | rates),
        heading_rad=draw(st.none() | angles),
    )


@st.composite
def covariances(draw: st.DrawFn, n: int) -> tuple[float, ...]:
    """Symmetric n x n, row-major, diagonal >= 0 (not necessarily PSD: not a wire rule)."""
    cov = [0.0] * (n * n)
    for i in range(n):
        cov[i * n + i] = draw(floats(0.0, 1e20))
        for j in range(i + 1, n):
            cov[i * n + j] = cov[j * n + i] = draw(floats(-1e20, 1e20))
    return tuple(cov)


predicted_points = st.builds(
    PredictedPoint,
    stamp_ns=stamps,
    position_enu_m=st.tuples(positions, positions),
    position_cov_m2=covariances(2),
)


@st.composite
def track_estimates(draw: st.DrawFn) -> TrackEstimate:
    model, n = draw(st.sampled_from([("cv2d", 4), ("ca2d", 6)]) | st.tuples(ids, st.integers(1, 16)))
    if model in ("cv2d", "ca2d"):
        n = {"cv2d": 4, "ca2d": 6}[model]
    return TrackEstimate(
        target_id=draw(ids),
        seq=draw(stamps),
        stamp_ns=draw(stamps),
        model=model,
        state=tuple(draw(st.lists(positions, min_size=n, max_size=n))),
        covariance=draw(covariances(n)),
        contributing_vehicles=tuple(draw(st.lists(ids, max_size=4))),
        prediction=tuple(draw(st.lists(predicted_points, max_size=6))),
    )


plan_commands = st.builds(
    PlanCommand,
    vehicle_id=ids,
    seq=stamps,
    stamp_ns=stamps,
    heading_rad=angles,
    turn_rate_rad_s=rates,
    airspeed_mps=floats(0.0, 1e3, exclude_min=True),
    altitude_m=altitudes,
    planned_path_enu_m=st.lists(st.tuples(positions, positions), max_size=10).map(tuple),
    planner=ids,
)
vehicle_statuses = st.builds(
    VehicleStatus,
    vehicle_id=ids,
    sysid=st.none() | st.integers(1, 250),
    link=st.sampled_from(["ok", "lost", "unknown"]),
    last_report_stamp_ns=st.none() | stamps,
    reports=st.integers(0, INT64_MAX),
    autopilot=st.none() | texts,
)
track_summaries = st.builds(
    TrackSummary,
    target_id=ids,
    stamp_ns=stamps,
    x_m=positions,
    y_m=positions,
    position_std_m=floats(0.0, 1e11),
    speed_mps=st.none() | floats(0.0, 1e9),
    contributing_vehicles=st.lists(ids, max_size=4).map(tuple),
)
daemon_statuses = st.builds(
    DaemonStatus,
    stamp_ns=stamps,
    uptime_s=floats(0.0, 1e10),
    scenario=texts,
    vehicles=st.lists(vehicle_statuses, max_size=4).map(tuple),
    counters=st.dictionaries(
        st.from_regex(r"[A-Za-z0-9_.:-]{1,64}", fullmatch=True), st.integers(0, INT64_MAX), max_size=5
    ),
    last_track_stamp_ns=st.none() | stamps,
    command_age_ms_median=st.none() | floats(-1e9, 1e12),
    command_age_ms_p99=st.none() | floats(-1e9, 1e12),
    tracks=st.lists(track_summaries, max_size=4).map(tuple),
)
target_truths = st.builds(
    TargetTruth,
    target_id=ids,
    seq=stamps,
    stamp_ns=stamps,
    position_enu_m=st.tuples(positions, positions),
    velocity_enu_mps=st.tuples(velocities, velocities),
)
vehicle_scenarios = st.builds(
    VehicleScenario,
    vehicle_id=ids,
    stamp_ns=stamps,
    scenario=ids,
    fingerprint=st.from_regex(r"[0-9a-f]{8,64}", fullmatch=True),
)

federated_tracks = st.builds(
    FederatedTrack,
    global_id=ids,
    born_ns=stamps,
    local_id=ids,
    stamp_ns=stamps,
    state=st.lists(positions, min_size=4, max_size=4).map(tuple),
    covariance=covariances(4),
    detected_ns=stamps,
)


@st.composite
def member_tracks(draw: st.DrawFn) -> MemberTracks:
    x_min, y_min = draw(floats(-1e8, 0.0)), draw(floats(-1e8, 0.0))
    vehicles = draw(st.integers(0, 100))
    return MemberTracks(
        member_id=draw(ids), seq=draw(stamps), stamp_ns=draw(stamps),
        area_enu_m=(x_min, y_min, draw(floats(1.0, 1e8)), draw(floats(1.0, 1e8))),
        team_xy_m=(draw(positions), draw(positions)), vehicles=vehicles,
        spare_vehicles=draw(st.integers(0, vehicles)),
        tracks=tuple(draw(st.lists(federated_tracks, max_size=3))),
        searching=tuple(draw(st.lists(ids, max_size=3))),
    )


STRATEGIES = {
    SensorReport: sensor_reports(),
    Measurement: measurements,
    GpsFix: gps_fixes,
    InsIncrement: ins_increments,
    NavReport: nav_reports(),
    PredictedPoint: predicted_points,
    TrackEstimate: track_estimates(),
    PlanCommand: plan_commands,
    VehicleStatus: vehicle_statuses,
    TrackSummary: track_summaries,
    DaemonStatus: daemon_statuses,
    TargetTruth: target_truths,
    VehicleScenario: vehicle_scenarios,
    FederatedTrack: federated_tracks,
    MemberTracks: member_tracks(),
}
any_message = st.one_of(*STRATEGIES.values())
ENCODINGS = [encoding_for(tp) for tp in MESSAGE_TYPES]


def test_every_message_type_has_a_strategy() -> None:
    assert set(STRATEGIES) == set(MESSAGE_TYPES)


# ---------------------------------------------------------------- round trip
@pytest.mark.parametrize("tp", MESSAGE_TYPES, ids=lambda tp: tp.__name__)
@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_round_trip(tp: type, data: st.DataObject) -> None:
    msg = data.draw(STRATEGIES[tp])
    payload, encoding = encode(msg)
    # DaemonStatus 2: heartbeat, liveliness, control; 3: age; 4: tracks. SensorReport 2: detections.
    version = {"DaemonStatus": 4, "SensorReport": 2}.get(tp.__name__, 1)
    assert encoding == f"application/json;gcs.{tp.__name__}/{version}"
    assert len(payload) <= MAX_PAYLOAD_BYTES
    back = decode(payload, encoding, expected=tp)
    assert type(back) is tp
    assert back == msg
    assert decode(payload, expected=tp) == msg  # encoding omitted: expected type decides


# ---------------------------------------------------------------- the earlier SensorReport
V1_ENCODING = "application/json;gcs.SensorReport/1"


@settings(max_examples=200, suppress_health_check=[HealthCheck.too_slow])
@given(old=sensor_reports_v1())
def test_a_v1_report_decodes_to_the_equivalent_v2(old: SensorReportV1) -> None:
    payload = msgspec.json.encode(old)
    for new in (decode(payload, V1_ENCODING, SensorReport), decode(payload, None, SensorReport)):
        assert type(new) is SensorReport
        assert (new.vehicle_id, new.seq, new.stamp_ns) == (old.vehicle_id, old.seq, old.stamp_ns)
        assert new.vehicle_position_enu_m == old.vehicle_position_enu_m
        assert new.vehicle_position_std_m == old.vehicle_position_std_m
        assert new.detected is old.detected and len(new.detections) == int(old.detected)
        if old.detected:
            d = new.detections[0]
            assert (d.range_m, d.azimuth_rad, d.elevation_rad) == (old.range_m, old.azimuth_rad, old.elevation_rad)
            assert (d.range_std_m, d.azimuth_std_rad, d.elevation_std_rad) == (
                old.range_std_m, old.azimuth_std_rad, old.elevation_std_rad)
        assert encode(new)[1] == "application/json;gcs.SensorReport/2"  # always written as the current version


def test_a_legacy_version_upgrades_only_a_message_of_its_own_struct() -> None:
    v1, = (old for old in LEGACY_VERSIONS if old.struct is SensorReportV1)
    report = SensorReport(vehicle_id="uav1", seq=1, stamp_ns=5, vehicle_position_enu_m=(0.0, 0.0, 100.0))
    with pytest.raises(ProtocolError, match="SensorReport is not a SensorReportV1") as info:
        v1.upgraded(report)
    assert info.value.reason == "unexpected_type"
    old = SensorReportV1(vehicle_id="uav1", seq=1, stamp_ns=5, vehicle_position_enu_m=(0.0, 0.0, 100.0), detected=False)
    assert v1.upgraded(old) == report


def test_a_v1_payload_is_judged_by_the_v1_rules_and_a_v2_encoding_refuses_it() -> None:
    v1 = {"vehicle_id": "uav1", "seq": 1, "stamp_ns": 5, "vehicle_position_enu_m": [0.0, 0.0, 100.0],
          "detected": False, "azimuth_rad": 0.1, "azimuth_std_rad": 0.01}
    with pytest.raises(ProtocolError, match="detected=false carries no measurement") as info:
        decode(json.dumps(v1).encode(), V1_ENCODING, SensorReport)
    assert info.value.field == "$.azimuth_rad" and "SensorReport/1" in info.value.message
    del v1["azimuth_rad"], v1["azimuth_std_rad"]
    with pytest.raises(ProtocolError, match="unknown field `detected`"):
        decode(json.dumps(v1).encode(), encoding_for(SensorReport), SensorReport)
    with pytest.raises(ProtocolError, match="reads 1, 2") as info:
        decode(json.dumps(v1).encode(), "application/json;gcs.SensorReport/3", SensorReport)
    assert info.value.reason == "encoding"


# ---------------------------------------------------------------- fuzzing
def assert_only_protocol_error(payload: bytes, encoding: str | None) -> object:
    """Decode; return the message or the ProtocolError. Any other exception fails the test."""
    try:
        return decode(payload, encoding)
    except ProtocolError as exc:
        assert str(exc)
        assert exc.field is None or exc.field.startswith("$")
        return exc


@settings(max_examples=300)
@given(payload=st.binary(max_size=512), encoding=st.sampled_from(ENCODINGS))
def test_arbitrary_bytes_raise_only_protocol_error(payload: bytes, encoding: str) -> None:
    out = assert_only_protocol_error(payload, encoding)
    assert isinstance(out, (ProtocolError, *MESSAGE_TYPES))


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@settings(max_examples=200)
@given(value=json_values, encoding=st.sampled_from(ENCODINGS))
def test_arbitrary_json_raises_only_protocol_error(value: object, encoding: str) -> None:
    payload = json.dumps(value).encode()  # may contain NaN / Infinity tokens
    out = assert_only_protocol_error(payload, encoding)
    assert isinstance(out, (ProtocolError, *MESSAGE_TYPES))


@settings(max_examples=300)
@given(
    encoding=st.text(max_size=60)
    | st.from_regex(r"application/json;gcs\.[A-Za-z]{0,14}/[0-9]{0,3}", fullmatch=True)
    | st.from_regex(r"[a-z/]{0,20};?gcs\.(SensorReport|NavReport)/-?[0-9]{0,2}", fullmatch=True)
)
def test_arbitrary_encoding_strings_raise_only_protocol_error(encoding: str) -> None:
    msg = SensorReport(
        vehicle_id="u", seq=0, stamp_ns=0, vehicle_position_enu_m=(0, 0, 0)
    )
    payload, good = encode(msg)
    out = assert_only_protocol_error(payload, encoding)
    if encoding == good:
        assert isinstance(out, SensorReport)
    else:
        assert isinstance(out, ProtocolError)


WRONG_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(), st.text(max_size=8),
    st.lists(st.integers(), max_size=3), st.just({"bogus key!": "x"}),
)


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(msg=any_message, data=st.data())
def test_mutated_valid_json_raises_only_protocol_error(msg: msgspec.Struct, data: st.DataObject) -> None:
    tp = type(msg)
    payload, encoding = encode(msg)
    obj = json.loads(payload)
    name = data.draw(st.sampled_from(sorted(obj)))
    required = {f.name for f in msgspec.structs.fields(tp) if f.required}
    if data.draw(st.booleans()):
        del obj[name]
        out = assert_only_protocol_error(json.dumps(obj).encode(), encoding)
        if name in required:
            assert isinstance(out, ProtocolError) and out.field == f"$.{name}"
            assert f"`{name}`" in str(out)
    else:
        obj[name] = data.draw(WRONG_VALUES)
        out = assert_only_protocol_error(json.dumps(obj).encode(), encoding)
        if obj[name] == {"bogus key!": "x"}:  # never valid for any field
            assert isinstance(out, ProtocolError) and out.field is not None
            assert out.field.startswith(f"$.{name}")
    assert isinstance(out, (ProtocolError, tp))


@pytest.mark.parametrize(
    "payload",
    [
        b"[" * 60000,
        b'{"counters":' + b"[" * 60000,
        b'{"scenario":' + b"{" * 30000,
        b'{"scenario":"\xff\xfe"}',  # invalid UTF-8 inside a string
        rb'{"scenario":"\ud800"}',  # lone surrogate escape
        b"\xef\xbb\xbf{}",  # byte-order mark
        b"",
    ],
)
def test_pathological_payloads_raise_protocol_error(payload: bytes) -> None:
    with pytest.raises(ProtocolError) as info:
        decode(payload, encoding_for(DaemonStatus))
    assert info.value.reason in {"malformed", "invalid"}
