"""Codec errors: each rejection names the field (or the bad encoding part) and its reason."""

from __future__ import annotations

import json
import math

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocols import (
    MAX_DETECTIONS,
    MAX_PAYLOAD_BYTES,
    DaemonStatus,
    Measurement,
    NavReport,
    PredictedPoint,
    ProtocolError,
    SensorReport,
    TrackEstimate,
    VehicleScenario,
    VehicleStatus,
    decode,
    encode,
    encoding_for,
)

# ---------------------------------------------------------------- named-field errors
DETECTION = Measurement(range_m=250.0, range_std_m=5.0, azimuth_rad=0.3, azimuth_std_rad=0.01)
REPORT = SensorReport(
    vehicle_id="uav1", seq=3, stamp_ns=1_000, vehicle_position_enu_m=(10.0, -20.0, 120.0),
    detections=(DETECTION, DETECTION),
)
ENC = encoding_for(SensorReport)


def _changed(obj: dict, changes: dict) -> dict:
    for key, value in changes.items():
        if value is ...:
            del obj[key]
        else:
            obj[key] = value
    return obj


def report_json(**changes: object) -> bytes:
    return json.dumps(_changed(json.loads(encode(REPORT)[0]), changes)).encode()


def detection_json(**changes: object) -> bytes:
    """The report with its second detection changed."""
    obj = json.loads(encode(REPORT)[0])
    _changed(obj["detections"][1], changes)
    return json.dumps(obj).encode()


@pytest.mark.parametrize(
    ("payload", "field"),
    [
        (report_json(detections="yes"), "$.detections"),  # wrong type
        (report_json(seq=1.5), "$.seq"),
        (report_json(vehicle_position_enu_m=...), "$.vehicle_position_enu_m"),  # missing
        (report_json(vehicle_id="uav 1"), "$.vehicle_id"),  # pattern
        (report_json(vehicle_id="uav1\n"), "$.vehicle_id"),  # Python's $ would allow this
        (report_json(seq=-1), "$.seq"),  # bound
        (detection_json(azimuth_rad=4.0), "$.detections[1].azimuth_rad"),
        (report_json(extra_field=1), "$.extra_field"),  # unknown field
        (detection_json(extra_field=1), "$.detections[1].extra_field"),
        (detection_json(azimuth_rad=..., azimuth_std_rad=...), "$.detections[1].azimuth_rad"),  # no azimuth
        (detection_json(azimuth_std_rad=None), "$.detections[1].azimuth_std_rad"),
        (detection_json(range_m=None), "$.detections[1].range_std_m"),  # std without value
        (detection_json(elevation_rad=-0.3), "$.detections[1].elevation_std_rad"),  # value without std
        (report_json(detections=[{"azimuth_rad": 0.1, "azimuth_std_rad": 0.1}] * (MAX_DETECTIONS + 1)),
         "$.detections"),  # too many
        (report_json().replace(b'"range_m": 250.0', b'"range_m": 1e999', 1), "$.detections[0].range_m"),  # inf
        (report_json().replace(b"-20.0", b"-1e999"), "$.vehicle_position_enu_m[1]"),
    ],
)
def test_decode_error_names_the_field(payload: bytes, field: str) -> None:
    with pytest.raises(ProtocolError) as info:
        decode(payload, ENC)
    assert info.value.field == field
    assert f"`{field}`" in str(info.value)
    assert info.value.reason == "invalid"


ANNOUNCEMENT = VehicleScenario(vehicle_id="uav1", stamp_ns=5, scenario="wang2012_urban", fingerprint="0123abcd" * 2)


@pytest.mark.parametrize(("changes", "field"), [
    ({"fingerprint": "0123ABCD"}, "$.fingerprint"),  # lower-case hex only
    ({"fingerprint": "0123abc"}, "$.fingerprint"),  # at least 8 digits
    ({"fingerprint": "0" * 65}, "$.fingerprint"),
    ({"fingerprint": "0123abcd\n"}, "$.fingerprint"),
    ({"scenario": "my city"}, "$.scenario"),  # a scenario name is an identifier
    ({"scenario": ...}, "$.scenario"),
    ({"vehicle_id": "uav/1"}, "$.vehicle_id"),
    ({"city": "x"}, "$.city"),  # unknown field
])
def test_a_scenario_announcement_is_refused_naming_the_field(changes: dict, field: str) -> None:
    payload = json.dumps(_changed(json.loads(encode(ANNOUNCEMENT)[0]), changes)).encode()
    with pytest.raises(ProtocolError) as info:
        decode(payload, encoding_for(VehicleScenario), VehicleScenario)
    assert info.value.field == field and info.value.reason == "invalid"


def test_a_scenario_announcement_travels_as_its_own_type_and_version() -> None:
    payload, encoding = encode(ANNOUNCEMENT)
    assert encoding == "application/json;gcs.VehicleScenario/1"
    assert json.loads(payload) == {"vehicle_id": "uav1", "stamp_ns": 5, "scenario": "wang2012_urban",
                                   "fingerprint": "0123abcd0123abcd"}
    with pytest.raises(ProtocolError) as info:  # never mistaken for a vehicle's report or nav
        decode(payload, encoding, NavReport)
    assert info.value.reason == "unexpected_type"


def test_nested_cross_field_error_has_the_full_path() -> None:
    good = PredictedPoint(stamp_ns=1, position_enu_m=(0, 0), position_cov_m2=(1, 0, 0, 1))
    track = TrackEstimate(
        target_id="t", seq=0, stamp_ns=1, model="cv2d", state=(0, 0, 0, 0),
        covariance=(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1),
        contributing_vehicles=("uav1",), prediction=(good, good),
    )
    obj = json.loads(encode(track)[0])
    obj["prediction"][1]["position_cov_m2"] = [1, 2, 0, 1]
    with pytest.raises(ProtocolError) as info:
        decode(json.dumps(obj).encode(), encoding_for(TrackEstimate))
    assert info.value.field == "$.prediction[1].position_cov_m2[1]"
    assert "not symmetric" in str(info.value) and "$.prediction[1]" in str(info.value)


def test_nan_token_in_json_text_is_malformed() -> None:
    payload = report_json().replace(b"250.0", b"NaN")
    with pytest.raises(ProtocolError) as info:
        decode(payload, ENC)
    assert info.value.reason == "malformed"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_encode_rejects_non_finite_floats_naming_the_path(bad: float) -> None:
    msg = msgspec.structs.replace(REPORT, vehicle_position_enu_m=(1.0, bad, 2.0))
    with pytest.raises(ProtocolError) as info:
        encode(msg)
    assert info.value.field == "$.vehicle_position_enu_m[1]"
    assert f"non-finite float {bad!r} at `$.vehicle_position_enu_m[1]`" in str(info.value)
    point = PredictedPoint(stamp_ns=1, position_enu_m=(0.0, bad), position_cov_m2=(1, 0, 0, 1))
    status = DaemonStatus(stamp_ns=0, uptime_s=bad, scenario="s", vehicles=())
    with pytest.raises(ProtocolError, match=r"\$\.position_enu_m\[1\]"):
        encode(point)
    with pytest.raises(ProtocolError, match=r"\$\.uptime_s"):
        encode(status)


_any_float = st.floats(allow_nan=True, allow_infinity=True) | st.floats(min_value=1e307, max_value=1.7e308)
_optional_float = st.none() | _any_float


@settings(max_examples=300, deadline=None)
@given(position=st.tuples(_any_float, _any_float, _any_float), std=_optional_float,
       azimuth=st.floats(min_value=-3.0, max_value=3.0) | st.sampled_from([math.nan, math.inf, -math.inf]))
def test_encode_never_passes_a_non_finite_float(position, std, azimuth) -> None:
    # The encoder looks closely only at payloads holding ``null``: NaN, the infinities and None all
    # encode to it. An optional field set to NaN would otherwise reach the wire as None.
    changes = {"vehicle_position_enu_m": position, "vehicle_position_std_m": std,
               "detections": (msgspec.structs.replace(DETECTION, azimuth_rad=azimuth),)}
    msg = msgspec.structs.replace(REPORT, **changes)
    values = [*position, std, azimuth]  # azimuth is required with a detection: never None
    # The wire's bounds, as protocols/fields.py documents them: positions within 1e8 m, a std in (0, 1e8] m.
    outside = [f"$.vehicle_position_enu_m[{i}]" for i, v in enumerate(position) if not abs(v) <= 1e8]
    outside += ["$.vehicle_position_std_m"] if std is not None and not 0.0 < std <= 1e8 else []
    if any(v is not None and not math.isfinite(v) for v in values):
        with pytest.raises(ProtocolError, match="non-finite float"):
            encode(msg)
    elif outside:  # finite, but outside a field's bounds: the first such field (in field order) is named
        with pytest.raises(ProtocolError) as refused:
            encode(msg)
        assert outside[0] in str(refused.value) and "non-finite" not in str(refused.value), (outside, refused.value)
    else:
        payload, _ = encode(msg)
        assert decode(payload, ENC) == msg


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_encode_catches_a_non_finite_float_beside_a_string_holding_null(bad: float) -> None:
    msg = msgspec.structs.replace(REPORT, vehicle_id="null", vehicle_position_std_m=bad)
    with pytest.raises(ProtocolError, match=r"\$\.vehicle_position_std_m"):
        encode(msg)
    assert decode(encode(msgspec.structs.replace(REPORT, vehicle_id="null"))[0], ENC).vehicle_id == "null"


def test_encode_refuses_what_decode_would_reject() -> None:
    with pytest.raises(ProtocolError) as info:
        encode(msgspec.structs.replace(REPORT, detections=(DETECTION, msgspec.structs.replace(DETECTION, azimuth_rad=7.0))))
    assert info.value.field == "$.detections[1].azimuth_rad"
    with pytest.raises(ProtocolError, match="not a registered message type"):
        encode(msgspec.json.Decoder())  # type: ignore[arg-type]
    big = DaemonStatus(
        stamp_ns=0, uptime_s=0.0, scenario="s",
        vehicles=tuple(
            VehicleStatus(vehicle_id=f"v{i}", link="ok", reports=0, autopilot="x" * 256)
            for i in range(256)
        ),
    )
    with pytest.raises(ProtocolError) as info:
        encode(big)
    assert info.value.reason == "oversize"


@pytest.mark.parametrize(
    ("encoding", "words"),
    [
        ("application/json;gcs.SensorReport/3", ["version", "'3'", "SensorReport", "reads 1, 2"]),
        ("application/json;gcs.SensorReport/0", ["version", "'0'"]),
        ("application/json;gcs.SensorReport/x", ["version", "'x'"]),
        ("application/json;gcs.Bogus/1", ["unknown message type", "'Bogus'"]),
        ("application/json;gcs.SensorReport", ["version"]),
        ("application/json;ros.SensorReport/1", ["gcs."]),
        ("application/json", ["gcs."]),
        ("text/plain;gcs.SensorReport/1", ["media type", "application/json"]),
        ("", ["media type"]),
    ],
)
def test_bad_encoding_says_what_is_wrong(encoding: str, words: list[str]) -> None:
    with pytest.raises(ProtocolError) as info:
        decode(encode(REPORT)[0], encoding)
    assert info.value.reason == "encoding"
    for word in words:
        assert word in str(info.value)


def test_expected_type_mismatch_and_missing_type() -> None:
    with pytest.raises(ProtocolError, match="expected NavReport.*SensorReport") as info:
        decode(encode(REPORT)[0], ENC, expected=NavReport)
    assert info.value.reason == "unexpected_type"
    with pytest.raises(ProtocolError, match="no encoding"):
        decode(encode(REPORT)[0])


def test_oversized_payload_rejected_before_parsing() -> None:
    valid, _ = encode(REPORT)
    padded = valid[:-1] + b" " * (MAX_PAYLOAD_BYTES - len(valid) + 1) + b"}"
    assert len(padded) == MAX_PAYLOAD_BYTES + 1
    with pytest.raises(ProtocolError) as info:
        decode(padded, ENC)
    assert info.value.reason == "oversize" and str(MAX_PAYLOAD_BYTES) in str(info.value)
    assert decode(padded[: MAX_PAYLOAD_BYTES - 1] + b"}", ENC) == REPORT  # at the limit: fine


@pytest.mark.parametrize("payload", ["{}", 42, None, [1, 2]])
def test_non_bytes_payloads(payload: object) -> None:
    with pytest.raises(ProtocolError):
        decode(payload, ENC)  # type: ignore[arg-type]
    assert decode(bytearray(encode(REPORT)[0]), ENC) == REPORT
    assert decode(memoryview(encode(REPORT)[0]), ENC) == REPORT
