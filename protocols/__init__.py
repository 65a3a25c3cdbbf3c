"""Wire protocol of the tracking ground station: messages, key expressions, codec.

Imports only the standard library and msgspec; no numpy, no I/O, no Zenoh.

- :mod:`protocols.messages`: frozen msgspec Structs (frames and units documented there);
  :mod:`protocols.sensor_report` holds the sensor's report of its detections and
  :mod:`protocols.legacy` the earlier versions still read;
  :mod:`protocols.vehicle_scenario` the scenario a vehicle announces;
  :mod:`protocols.status` holds the daemon's health (its vehicles and tracks) and
  :mod:`protocols.base` their common base.
- :mod:`protocols.keys`: the Zenoh key space, builders, selectors and :func:`parse_key`.
- :mod:`protocols.codec`: :func:`encode` / :func:`decode` with the Zenoh encoding
  ``application/json;gcs.<TypeName>/<VERSION>``.
- :mod:`protocols.errors`: :class:`ProtocolError`, the only exception for wire problems.
"""

from protocols.codec import (
    MAX_PAYLOAD_BYTES,
    decode,
    encode,
    encoding_for,
    json_schema,
    parse_encoding,
    wire_version,
)
from protocols.errors import REJECT_REASONS, ProtocolError
from protocols.keys import (
    DEFAULT_PREFIX,
    KEY_KINDS,
    MESSAGE_TYPE_BY_KIND,
    ParsedKey,
    alive_key,
    alive_selector,
    member_alive_key,
    member_alive_selector,
    member_tracks_key,
    member_tracks_selector,
    nav_key,
    navs_selector,
    parse_key,
    plan_key,
    plans_selector,
    report_key,
    reports_selector,
    scenario_key,
    scenarios_selector,
    status_key,
    track_key,
    tracks_selector,
    truth_key,
    truth_selector,
    validate_id,
    validate_prefix,
)
from protocols.messages import (
    MAX_DETECTIONS,
    MESSAGE_TYPES,
    TRACK_MODEL_DIMS,
    DaemonStatus,
    FederatedTrack,
    GpsFix,
    InsIncrement,
    Measurement,
    MemberTracks,
    Message,
    NavReport,
    PlanCommand,
    PredictedPoint,
    SensorReport,
    TargetTruth,
    TrackEstimate,
    TrackSummary,
    VehicleScenario,
    VehicleStatus,
)

__all__ = [
    "DEFAULT_PREFIX",
    "KEY_KINDS",
    "MAX_DETECTIONS",
    "MAX_PAYLOAD_BYTES",
    "MESSAGE_TYPES",
    "MESSAGE_TYPE_BY_KIND",
    "REJECT_REASONS",
    "TRACK_MODEL_DIMS",
    "DaemonStatus",
    "FederatedTrack",
    "GpsFix",
    "InsIncrement",
    "Measurement",
    "MemberTracks",
    "Message",
    "NavReport",
    "ParsedKey",
    "PlanCommand",
    "PredictedPoint",
    "ProtocolError",
    "SensorReport",
    "TargetTruth",
    "TrackEstimate",
    "TrackSummary",
    "VehicleScenario",
    "VehicleStatus",
    "alive_key",
    "alive_selector",
    "decode",
    "encode",
    "encoding_for",
    "json_schema",
    "member_alive_key",
    "member_alive_selector",
    "member_tracks_key",
    "member_tracks_selector",
    "nav_key",
    "navs_selector",
    "parse_encoding",
    "parse_key",
    "plan_key",
    "plans_selector",
    "report_key",
    "reports_selector",
    "scenario_key",
    "scenarios_selector",
    "status_key",
    "track_key",
    "tracks_selector",
    "truth_key",
    "truth_selector",
    "validate_id",
    "validate_prefix",
    "wire_version",
]
