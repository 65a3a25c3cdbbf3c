"""What the daemon knows of one vehicle from MAVLink, and how each message changes it (pure).

Telemetry is converted at this edge (docs/design.md, frames, units and time): GLOBAL_POSITION_INT
lat/lon -> ENU x, y through the scenario frame (origin = home), relative_alt ->
ENU z; NED velocity (cm/s) -> ENU m/s; ``hdg`` (or ATTITUDE.yaw) NED -> ENU heading.
Arrivals of the streamed messages the daemon asks rates for
(:data:`STREAMED_TELEMETRY`) are counted, so that the commander can check that
the rates asked for arrive.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.adapters.mavlink_wire import (ARDUPLANE_MODE_NAMES, ARDUPLANE_MODES, before_gps_fix, mavlink,
                                      ned_yaw_from_enu_heading)
from gcs.core.geometry import LocalFrame
from gcs.core.steering import CourseLoop, PlannedPath, follow

__all__ = ["GUIDED", "MAX_ABS_ALTITUDE_M", "PX4_OFFBOARD_MAIN_MODE", "STREAMED_TELEMETRY", "HeadingCommand",
           "VehicleLink", "in_guided_mode", "steering_command", "update_from_message"]

GUIDED = ARDUPLANE_MODES["GUIDED"]
PX4_OFFBOARD_MAIN_MODE = 6
"""PX4 main mode OFFBOARD: HEARTBEAT.custom_mode bits 16-23; DO_SET_MODE param2 (docs/mavlink.md)."""
MAX_ABS_ALTITUDE_M = 100_000.0
"""Altitudes relative to home beyond this are not a fixed-wing's (telemetry rejected as ``bad_telemetry``)."""
STREAMED_TELEMETRY: dict[str, int] = {"GLOBAL_POSITION_INT": mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                                      "ATTITUDE": mavlink.MAVLINK_MSG_ID_ATTITUDE}
"""The messages the daemon steers from, by name and id: it asks each vehicle for them at a set rate."""
_UNKNOWN_HDG = 65535


@dataclass(frozen=True)
class HeadingCommand:
    """What one vehicle is asked to fly: ENU course (rad), altitude relative to home (m), airspeed (m/s).

    The course is the steering's, lead included (:mod:`gcs.core.steering`): an ArduPilot peer is
    told it (GUIDED_CHANGE_HEADING), a peer that takes setpoints (PX4) gets a carrot along it.
    """

    heading_enu_rad: float
    altitude_m: float
    airspeed_mps: float

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.heading_enu_rad, self.altitude_m, self.airspeed_mps)):
            raise ValueError(f"a heading command needs finite values, got {self}")
        if not self.airspeed_mps > 0:
            raise ValueError(f"airspeed_mps must be > 0, got {self.airspeed_mps}")


@dataclass
class VehicleLink:
    """What the daemon knows about one vehicle from MAVLink (times on the clock passed to ``poll``)."""

    vehicle_id: str
    sysid: int
    autopilot: int | None = None
    custom_mode: int | None = None
    armed: bool = False
    last_heartbeat_s: float | None = None
    position_enu_m: NDArray[np.float64] | None = None
    velocity_enu_mps: NDArray[np.float64] | None = None
    heading_enu_rad: float | None = None
    position_stamp_s: float | None = None
    command: HeadingCommand | None = None
    counters: Counter = field(default_factory=Counter)
    arrivals: Counter = field(default_factory=Counter)
    """Messages of :data:`STREAMED_TELEMETRY` received, by name."""
    last_ack: dict[int, int] = field(default_factory=dict)
    """Result of the latest COMMAND_ACK per command id."""

    def position_age_s(self, now_s: float) -> float:
        """Seconds from when the latest position was heard to ``now_s`` (0 before any, never negative)."""
        return 0.0 if self.position_stamp_s is None else max(now_s - self.position_stamp_s, 0.0)

    @property
    def mode_name(self) -> str:
        """ArduPlane name of the reported mode (the number for other autopilots)."""
        if self.custom_mode is None:
            return "unknown"
        if self.autopilot == mavlink.MAV_AUTOPILOT_PX4:
            return str(self.custom_mode)
        return ARDUPLANE_MODE_NAMES.get(self.custom_mode, str(self.custom_mode))

    @property
    def is_ardupilot(self) -> bool:
        """The HEARTBEAT names ArduPilot: steered by GUIDED_CHANGE_HEADING, not by carrots."""
        return self.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA

    def heard_since(self, since_s: float) -> bool:
        """A HEARTBEAT or a position received at ``since_s`` or later."""
        return any(t is not None and t >= since_s for t in (self.last_heartbeat_s, self.position_stamp_s))

    def alive(self, now_s: float, timeout_s: float) -> bool:
        """A HEARTBEAT within ``timeout_s`` of ``now_s``."""
        return self.last_heartbeat_s is not None and now_s - self.last_heartbeat_s <= timeout_s

    def course_rad(self) -> float | None:
        """Course over ground from the reported velocity (the heading when slower than 1 m/s, or unknown)."""
        velocity = self.velocity_enu_mps
        if velocity is not None and math.hypot(velocity[0], velocity[1]) >= 1.0:
            return math.atan2(velocity[1], velocity[0])
        return self.heading_enu_rad

    def ground_speed_mps(self) -> float | None:
        """Horizontal speed from the reported velocity."""
        velocity = self.velocity_enu_mps
        return None if velocity is None else float(math.hypot(velocity[0], velocity[1]))


def update_from_message(link: VehicleLink, message, now_s: float, frame: LocalFrame) -> str | None:
    """Apply one message from the vehicle to ``link``; returns ``"heartbeat"`` for a vehicle HEARTBEAT and
    ``"bad_telemetry"`` for a position off the globe (or beyond :data:`MAX_ABS_ALTITUDE_M`), a heading out of
    range or a non-finite yaw, and ``"no_fix"`` for a position at about lat = lon = 0 (what an autopilot
    sends before its GPS has a fix, :func:`~gcs.adapters.mavlink_wire.before_gps_fix`), which change nothing (the caller counts them).

    GLOBAL_POSITION_INT: ``x, y`` from lat/lon through ``frame`` (at the origin
    height plus ``relative_alt``), ``z = relative_alt``; velocity NED cm/s ->
    ENU ``(vy, vx, -vz) / 100``; ``hdg`` (cdeg, 65535 = unknown) NED -> ENU.
    ATTITUDE: ``yaw`` NED -> ENU heading. HEARTBEATs of ground stations and
    companions (autopilot ``MAV_AUTOPILOT_INVALID``) are not the vehicle's.
    """
    kind = message.get_type()
    if kind == "HEARTBEAT":
        if message.autopilot == mavlink.MAV_AUTOPILOT_INVALID or message.type == mavlink.MAV_TYPE_GCS:
            return None
        link.autopilot, link.custom_mode = int(message.autopilot), int(message.custom_mode)
        link.armed = bool(message.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        link.last_heartbeat_s = now_s
        return "heartbeat"
    if kind == "GLOBAL_POSITION_INT":
        if before_gps_fix(message.lat, message.lon):  # an autopilot without a GPS fix yet reports about 0, 0
            link.arrivals[kind] += 1  # the stream flows at its rate all the same
            return "no_fix"
        lat, lon, altitude_m = message.lat * 1e-7, message.lon * 1e-7, message.relative_alt * 1e-3
        if not (abs(lat) <= 90.0 and abs(lon) <= 180.0 and abs(altitude_m) <= MAX_ABS_ALTITUDE_M
                and (message.hdg == _UNKNOWN_HDG or message.hdg < 36000)):
            return "bad_telemetry"
        enu = frame.to_enu(lat, lon, frame.height_m + altitude_m)
        if not (math.isfinite(enu[0]) and math.isfinite(enu[1])):
            return "bad_telemetry"
        link.position_enu_m = np.array([enu[0], enu[1], altitude_m])
        link.velocity_enu_mps = np.array([message.vy, message.vx, -message.vz], dtype=np.float64) * 1e-2
        if message.hdg != _UNKNOWN_HDG:
            link.heading_enu_rad = ned_yaw_from_enu_heading(math.radians(message.hdg * 1e-2))
        link.position_stamp_s = now_s
        link.arrivals[kind] += 1
    elif kind == "ATTITUDE":
        if not math.isfinite(message.yaw):
            return "bad_telemetry"
        link.heading_enu_rad = ned_yaw_from_enu_heading(float(message.yaw))
        link.arrivals[kind] += 1
    return None


def in_guided_mode(autopilot: int | None, custom_mode: int | None) -> bool:
    """Whether a HEARTBEAT's mode takes external guidance: PX4 OFFBOARD, else ArduPilot GUIDED (15)."""
    if custom_mode is None:
        return False
    if autopilot == mavlink.MAV_AUTOPILOT_PX4:
        return (custom_mode >> 16) & 0xFF == PX4_OFFBOARD_MAIN_MODE
    return custom_mode == GUIDED


def steering_command(link: VehicleLink, path: PlannedPath, loop: CourseLoop, period_s: float,
                     latency_s: float = 0.0) -> HeadingCommand | None:
    """The command that steers the vehicle along ``path`` from its latest telemetry (:func:`gcs.core.steering.follow`
    with the lead of ``loop``), or None before a position, a course and a speed are known."""
    course, speed = link.course_rad(), link.ground_speed_mps()
    if link.position_enu_m is None or course is None or speed is None:
        return None
    steering = follow(path, link.position_enu_m, course, speed, loop, period_s=period_s, latency_s=latency_s)
    return HeadingCommand(steering.command_course_rad, path.altitude_m, path.airspeed_mps)
