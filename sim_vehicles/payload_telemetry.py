"""An autopilot's telemetry as the payload bridge (:mod:`sim_vehicles.payload`) reads it: the pose, the GPS
status, and what makes a message bad. Pure: messages and the bridge's clock come in.

What comes from where
---------------------
- **GLOBAL_POSITION_INT**: the position, ``lat``/``lon`` through the scenario's
  :class:`~gcs.core.geometry.LocalFrame` (origin = home) at the origin height plus
  ``relative_alt``, with ``z = relative_alt``; the ground velocity, NED cm/s to ENU
  m/s; ``hdg`` as the heading until an ATTITUDE comes.
- **ATTITUDE**: heading (``yaw``, NED to ENU), roll, pitch, and the turn rate
  (``-yawspeed``: NED yaw rate is clockwise, ENU counter-clockwise).
- **GPS_RAW_INT**: ``fix_type``, ``satellites_visible`` (255: unknown) and the 1-sigma
  accuracy: ``h_acc``/``v_acc`` (mm, MAVLink 2) when the receiver gives them, else
  ``eph``/``epv`` (HDOP/VDOP x 100) times :data:`USER_RANGE_ERROR_M` per axis.

Bad telemetry (a position off the globe or over :data:`MAX_DISTANCE_FROM_HOME_M` from home, as a
receiver without a fix reports 0, 0; non-finite attitude; a fix type or heading out of range) raises
:class:`BadTelemetry`, and changes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.adapters.mavlink_wire import before_gps_fix, ned_yaw_from_enu_heading
from gcs.core.geometry import LocalFrame, wrap_angle

__all__ = ["BadTelemetry", "GpsStatus", "NoFix", "MAX_DISTANCE_FROM_HOME_M", "Pose", "USER_RANGE_ERROR_M", "VehicleTelemetry",
           "gps_status", "position_from_global"]

USER_RANGE_ERROR_M = 3.0
"""Per-axis 1-sigma error per unit of dilution of precision, when GPS_RAW_INT gives no ``h_acc``/``v_acc``
(a typical single-frequency receiver's user-equivalent range error)."""
MAX_DISTANCE_FROM_HOME_M = 100_000.0
"""A position farther from home than this (horizontally) is bad telemetry: no fixed-wing of a tracking team is
there, but a receiver without a fix reports lat = lon = 0."""
MAX_ABS_ALTITUDE_M = 20_000.0  # beyond this relative to home: bad telemetry
_UNKNOWN_U16, _UNKNOWN_SATELLITES = 65535, 255


class BadTelemetry(ValueError):
    """A telemetry message that cannot be a pose (the message says why)."""


class NoFix(BadTelemetry):
    """A GLOBAL_POSITION_INT at about lat = lon = 0: what an autopilot sends before its GPS has a fix
    (:func:`gcs.adapters.mavlink_wire.before_gps_fix`)."""


@dataclass(frozen=True)
class Pose:
    """A vehicle's pose in the scenario's ENU frame: position (3,) m, ground velocity (3,) m/s, heading (ENU,
    from east counter-clockwise), roll and pitch (rad), turn rate (rad/s, counter-clockwise)."""

    position_enu_m: NDArray[np.float64]
    velocity_enu_mps: NDArray[np.float64]
    heading_rad: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    turn_rate_rad_s: float = 0.0


@dataclass(frozen=True)
class GpsStatus:
    """What GPS_RAW_INT says of the fix: MAVLink ``GPS_FIX_TYPE``, 1-sigma per horizontal axis and vertical
    (m), satellites used (None: unknown)."""

    fix_type: int
    h_acc_m: float
    v_acc_m: float
    satellites: int | None


def position_from_global(message, frame: LocalFrame) -> tuple[NDArray[np.float64], NDArray[np.float64], float | None]:
    """GLOBAL_POSITION_INT -> ``(position (3,) ENU m, velocity (3,) ENU m/s, heading ENU rad or None)``.

    ``x, y`` from ``lat``/``lon`` (1e7 degrees) at the origin height plus ``relative_alt`` (mm), ``z =
    relative_alt``; velocity ``(vy, vx, -vz) / 100``; ``hdg`` (cdeg NED, 65535 unknown). :class:`NoFix` near
    lat = lon = 0, BadTelemetry for a position off the globe, too high or too far from home, or a heading out
    of range.
    """
    if before_gps_fix(message.lat, message.lon):
        raise NoFix(f"position lat {message.lat * 1e-7:g}, lon {message.lon * 1e-7:g}: no GPS fix yet")
    lat, lon, altitude_m = message.lat * 1e-7, message.lon * 1e-7, message.relative_alt * 1e-3
    if not (abs(lat) <= 90.0 and abs(lon) <= 180.0):
        raise BadTelemetry(f"position lat {lat:g}, lon {lon:g} is off the globe")
    if not abs(altitude_m) <= MAX_ABS_ALTITUDE_M:
        raise BadTelemetry(f"relative altitude {altitude_m:g} m is beyond {MAX_ABS_ALTITUDE_M:g} m")
    if not (message.hdg == _UNKNOWN_U16 or 0 <= message.hdg < 36000):
        raise BadTelemetry(f"heading {message.hdg} cdeg is out of range")
    enu = frame.to_enu(lat, lon, frame.height_m + altitude_m)
    if not (math.hypot(enu[0], enu[1]) <= MAX_DISTANCE_FROM_HOME_M):
        raise BadTelemetry(f"position lat {lat:.7f}, lon {lon:.7f} is {math.hypot(enu[0], enu[1]) / 1e3:.0f} km "
                           "from home")
    position = np.array([enu[0], enu[1], altitude_m])
    velocity = np.array([message.vy, message.vx, -message.vz], dtype=np.float64) * 1e-2
    heading = None if message.hdg == _UNKNOWN_U16 else ned_yaw_from_enu_heading(math.radians(message.hdg * 1e-2))
    return position, velocity, heading


def gps_status(message) -> GpsStatus:
    """GPS_RAW_INT -> :class:`GpsStatus` (see the module docstring); BadTelemetry for a fix type above 8."""
    if not 0 <= message.fix_type <= 8:
        raise BadTelemetry(f"GPS fix type {message.fix_type} is out of range")

    def accuracy(acc_mm: int, dop_x100: int) -> float:
        if acc_mm > 0:
            return acc_mm * 1e-3
        if 0 < dop_x100 < _UNKNOWN_U16:
            return dop_x100 * 1e-2 * USER_RANGE_ERROR_M
        return math.nan

    satellites = None if message.satellites_visible == _UNKNOWN_SATELLITES else int(message.satellites_visible)
    return GpsStatus(int(message.fix_type), accuracy(getattr(message, "h_acc", 0), message.eph),
                     accuracy(getattr(message, "v_acc", 0), message.epv), satellites)


class VehicleTelemetry:
    """One vehicle's latest telemetry, on the bridge's clock (seconds since launch)."""

    def __init__(self, frame: LocalFrame) -> None:
        self.frame = frame
        self.position_enu_m: NDArray[np.float64] | None = None
        self.velocity_enu_mps = np.zeros(3)
        self.position_s: float | None = None
        self.heading_rad: float | None = None
        self.heading_s = 0.0
        self.roll_rad = self.pitch_rad = self.turn_rate_rad_s = 0.0
        self.attitude = False
        self.gps: GpsStatus | None = None

    def ingest(self, message, now_s: float) -> None:
        """Take one message (other types are ignored); BadTelemetry, changing nothing, for a bad one."""
        kind = message.get_type()
        if kind == "GLOBAL_POSITION_INT":
            position, velocity, heading = position_from_global(message, self.frame)
            self.position_enu_m, self.velocity_enu_mps, self.position_s = position, velocity, now_s
            if heading is not None and not self.attitude:
                self.heading_rad, self.heading_s = heading, now_s
        elif kind == "ATTITUDE":
            values = (message.yaw, message.roll, message.pitch, message.yawspeed)
            if not all(math.isfinite(v) for v in values) or not abs(message.yaw) <= 2.0 * math.pi:
                raise BadTelemetry(f"attitude yaw {message.yaw}, roll {message.roll}, pitch {message.pitch}, "
                                   f"yaw rate {message.yawspeed}")
            self.heading_rad, self.heading_s = ned_yaw_from_enu_heading(float(message.yaw)), now_s
            self.roll_rad, self.pitch_rad = float(message.roll), float(message.pitch)
            self.turn_rate_rad_s, self.attitude = -float(message.yawspeed), True
        elif kind == "GPS_RAW_INT":
            self.gps = gps_status(message)

    def fresh(self, now_s: float, stale_after_s: float) -> bool:
        """A good GLOBAL_POSITION_INT at most ``stale_after_s`` ago."""
        return self.position_s is not None and now_s - self.position_s <= stale_after_s

    def pose(self, now_s: float) -> Pose:
        """The pose at ``now_s``: the last position moved on by its velocity, the heading by the turn rate (back,
        for a time just before they arrived: a report for the physics step the newest telemetry fell in)."""
        if self.position_enu_m is None or self.position_s is None:
            raise ValueError("no position yet")
        ahead = now_s - self.position_s
        heading = self.heading_rad
        if heading is None:  # neither hdg nor ATTITUDE: the course over the ground
            heading = math.atan2(self.velocity_enu_mps[1], self.velocity_enu_mps[0])
        else:
            heading = wrap_angle(heading + self.turn_rate_rad_s * (now_s - self.heading_s))
        return Pose(self.position_enu_m + self.velocity_enu_mps * ahead, self.velocity_enu_mps.copy(),
                    float(heading), self.roll_rad, self.pitch_rad, self.turn_rate_rad_s)
