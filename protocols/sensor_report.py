"""A vehicle's sensor report: zero or more detections, each a measurement without identity.

A sensor sees what is in its field: the target it is pointed at, other vehicles on the
ground, and false alarms (clutter). A report therefore lists every detection of one
scan, in no particular order, and none says which object made it; deciding that
(data association) is the estimator's job.

Frames and units are those of :mod:`protocols.messages`: azimuth ``atan2(dy, dx)`` from
east counter-clockwise, elevation ``atan2(dz, horizontal distance)``, range the 3-D
distance, all of target minus vehicle.

Versions
--------
This is version 2 of ``SensorReport``. Version 1 (one measurement, ``detected``,
``target_id``) still decodes: :mod:`protocols.legacy` upgrades it at the codec.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from msgspec import Meta

from protocols.base import Message
from protocols.errors import ProtocolError
from protocols.fields import AngleRad, DistanceM, ElevationRad, Ident, PositionM, Seq, StampNs, StdM, StdRad

__all__ = ["MAX_DETECTIONS", "Measurement", "SensorReport", "check_pairs"]

#: Most detections one report may carry (a scan's targets and clutter together).
MAX_DETECTIONS = 64


def check_pairs(values: tuple[tuple[str, float | None, str, float | None], ...], path: str = "$") -> None:
    """Raise :class:`ProtocolError` unless every value comes with its standard deviation and vice versa.

    ``values`` holds ``(name, value, std_name, std)`` rows; the error names the field at ``path``.
    """
    for name, value, std_name, std in values:
        if value is None and std is not None:
            raise ProtocolError(f"{std_name} is given without {name}", field=f"{path}.{std_name}")
        if value is not None and std is None:
            raise ProtocolError(f"{name} is given without {std_name}", field=f"{path}.{std_name}")


class Measurement(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One detection: what the sensor measured of one object, with its noise; no identity.

    Attributes
    ----------
    azimuth_rad, azimuth_std_rad : float
        Bearing of the object and its 1-sigma noise: every detection has one.
    range_m, range_std_m : float or None
        Slant range and its 1-sigma (bearing-only sensors omit both).
    elevation_rad, elevation_std_rad : float or None
        Elevation and its 1-sigma, if measured.

    A value is given if and only if its standard deviation is.
    """

    range_m: DistanceM | None = None
    azimuth_rad: AngleRad
    elevation_rad: ElevationRad | None = None
    range_std_m: StdM | None = None
    azimuth_std_rad: StdRad
    elevation_std_rad: StdRad | None = None

    def __post_init__(self) -> None:
        check_pairs((("range_m", self.range_m, "range_std_m", self.range_std_m),
                     ("elevation_rad", self.elevation_rad, "elevation_std_rad", self.elevation_std_rad)))


class SensorReport(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One scan of one vehicle's sensor: where the vehicle was and every detection it made.

    Attributes
    ----------
    vehicle_id, seq, stamp_ns
        Publisher, its sequence number and the measurement time (ns).
    vehicle_position_enu_m : tuple of 3 float
        The vehicle's position as the vehicle itself knows it (ENU, m).
    vehicle_position_std_m : float or None
        1-sigma of that position per axis (m), if known.
    detections : tuple of Measurement
        The scan's detections, at most :data:`MAX_DETECTIONS`, in no meaningful order;
        empty when nothing was seen (occluded, out of the field, missed).
    """

    VERSION: ClassVar[int] = 2

    vehicle_id: Ident
    seq: Seq
    stamp_ns: StampNs
    vehicle_position_enu_m: tuple[PositionM, PositionM, PositionM]
    vehicle_position_std_m: StdM | None = None
    detections: Annotated[tuple[Measurement, ...], Meta(max_length=MAX_DETECTIONS)] = ()

    def __post_init__(self) -> None:
        if len(self.detections) > MAX_DETECTIONS:
            raise ProtocolError(f"detections has {len(self.detections)} entries, at most {MAX_DETECTIONS} allowed",
                                field="$.detections")
        for k, detection in enumerate(self.detections):
            if not isinstance(detection, Measurement):
                raise ProtocolError(f"detections[{k}] is a {type(detection).__name__}, not a Measurement",
                                    field=f"$.detections[{k}]")

    @property
    def detected(self) -> bool:
        """True when the scan saw anything (at least one detection)."""
        return bool(self.detections)
