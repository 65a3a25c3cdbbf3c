"""Earlier wire versions the codec still reads, and how each becomes the current message.

A legacy version is decoded and validated by its own Struct, with the rules it had,
then upgraded: the receiver only ever sees the current type. Nothing is encoded in
a legacy version.

- ``SensorReport/1``: one measurement per report, ``detected`` saying whether it is
  there, and the ``target_id`` looked for. It becomes a ``SensorReport/2`` with no
  detection (``detected = false``) or one (``detected = true``), the measurement's
  values and standard deviations unchanged; ``target_id`` is dropped, since a
  detection carries no identity.
- ``DaemonStatus/3``: the status without its tracks. It becomes a ``DaemonStatus/4``
  with every field as it was and no tracks (``tracks = ()``). Every version-3 payload
  is a valid version-4 one, so one without an encoding string decodes as version 4
  directly; only the encoding ``gcs.DaemonStatus/3`` selects the version-3 Struct.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, ClassVar, Generic, TypeVar

import msgspec
from msgspec import Meta

from protocols.base import Message
from protocols.errors import ProtocolError
from protocols.fields import (AngleRad, CommandAgeMs, Count, CounterName, DistanceM, ElevationRad, Ident, PositionM,
                              Seq, StampNs, StdM, StdRad, Text, UptimeS)
from protocols.sensor_report import Measurement, SensorReport, check_pairs
from protocols.status import DaemonStatus, VehicleStatus

__all__ = [
    "LEGACY_VERSIONS",
    "AnyLegacyVersion",
    "DaemonStatusV3",
    "LegacyVersion",
    "SensorReportV1",
    "upgrade_daemon_status_v3",
    "upgrade_sensor_report_v1",
]


class SensorReportV1(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``SensorReport`` version 1: one target measurement (or none) by one vehicle's sensor.

    ``detected = false`` carries no measurement values at all; ``detected = true`` has
    at least ``azimuth_rad``; each value is given if and only if its ``*_std_*`` is.
    """

    VERSION: ClassVar[int] = 1

    vehicle_id: Ident
    seq: Seq
    stamp_ns: StampNs
    target_id: Ident = "target"
    vehicle_position_enu_m: tuple[PositionM, PositionM, PositionM]
    vehicle_position_std_m: StdM | None = None
    detected: bool
    range_m: DistanceM | None = None
    azimuth_rad: AngleRad | None = None
    elevation_rad: ElevationRad | None = None
    range_std_m: StdM | None = None
    azimuth_std_rad: StdRad | None = None
    elevation_std_rad: StdRad | None = None

    def __post_init__(self) -> None:
        values = (
            ("range_m", self.range_m, "range_std_m", self.range_std_m),
            ("azimuth_rad", self.azimuth_rad, "azimuth_std_rad", self.azimuth_std_rad),
            ("elevation_rad", self.elevation_rad, "elevation_std_rad", self.elevation_std_rad),
        )
        if not self.detected:
            for name, value, _, _ in values:
                if value is not None:
                    raise ProtocolError(f"detected=false carries no measurement, but {name} is given",
                                        field=f"$.{name}")
        check_pairs(values)
        if self.detected and self.azimuth_rad is None:
            raise ProtocolError("detected=true needs at least azimuth_rad", field="$.azimuth_rad")


def upgrade_sensor_report_v1(old: SensorReportV1) -> SensorReport:
    """The version-2 report equal to a version-1 one: no detection, or its one measurement."""
    detections: tuple[Measurement, ...] = ()
    # A detection has an azimuth and its standard deviation (SensorReportV1.__post_init__).
    if old.detected and old.azimuth_rad is not None and old.azimuth_std_rad is not None:
        detections = (Measurement(range_m=old.range_m, azimuth_rad=old.azimuth_rad, elevation_rad=old.elevation_rad,
                                  range_std_m=old.range_std_m, azimuth_std_rad=old.azimuth_std_rad,
                                  elevation_std_rad=old.elevation_std_rad),)
    return SensorReport(vehicle_id=old.vehicle_id, seq=old.seq, stamp_ns=old.stamp_ns,
                        vehicle_position_enu_m=old.vehicle_position_enu_m,
                        vehicle_position_std_m=old.vehicle_position_std_m, detections=detections)


class DaemonStatusV3(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """``DaemonStatus`` version 3: the daemon's health without its tracks (fields as in version 4)."""

    VERSION: ClassVar[int] = 3

    stamp_ns: StampNs
    uptime_s: UptimeS
    scenario: Text
    vehicles: Annotated[tuple[VehicleStatus, ...], Meta(max_length=256)]
    counters: dict[CounterName, Count] = msgspec.field(default_factory=dict)
    last_track_stamp_ns: StampNs | None = None
    command_age_ms_median: CommandAgeMs | None = None
    command_age_ms_p99: CommandAgeMs | None = None


def upgrade_daemon_status_v3(old: DaemonStatusV3) -> DaemonStatus:
    """The version-4 status equal to a version-3 one: every field as it was, no tracks."""
    return DaemonStatus(**msgspec.structs.asdict(old), tracks=())


Old = TypeVar("Old", bound=Message)


@dataclass(frozen=True)
class LegacyVersion(Generic[Old]):
    """An earlier ``version`` of ``current``: decoded as ``struct``, then ``upgrade``\\ d.

    ``marker`` is a JSON key only that version has: a payload that arrives without an
    encoding string, fails as the current version and holds the marker is read as this one.
    It is None when the current version accepts every payload of the earlier one (the
    current version only adds fields with defaults): such a payload decodes as the current
    version, and one the current version rejects the earlier one rejects too, so only its
    encoding string selects the earlier Struct.
    """

    current: type[Message]
    version: int
    struct: type[Old]
    upgrade: Callable[[Old], Message]
    marker: bytes | None

    def upgraded(self, message: Message) -> Message:
        """``upgrade(message)`` for a message decoded as ``struct``; ProtocolError for any other."""
        if not isinstance(message, self.struct):
            raise ProtocolError(f"{type(message).__name__} is not a {self.struct.__name__}", reason="unexpected_type")
        return self.upgrade(message)


AnyLegacyVersion = LegacyVersion[SensorReportV1] | LegacyVersion[DaemonStatusV3]
"""The legacy versions the codec reads, one member per earlier Struct."""

LEGACY_VERSIONS: tuple[AnyLegacyVersion, ...] = (
    LegacyVersion(SensorReport, 1, SensorReportV1, upgrade_sensor_report_v1, b'"detected"'),
    LegacyVersion(DaemonStatus, 3, DaemonStatusV3, upgrade_daemon_status_v3, None),
)
"""Every earlier version the codec reads."""
