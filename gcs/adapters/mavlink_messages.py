"""The commands the daemon sends a vehicle, each one MAVLink message: its fields, its encoding, and the counter
that counts it (what is sent when is :mod:`gcs.adapters.mavlink_commands`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gcs.adapters.mavlink_wire import mavlink, ned_yaw_from_enu_heading

__all__ = ["CARROT_TYPE_MASK", "Carrot", "ModeRequest", "Arm", "MessageInterval", "ChangeHeading", "ChangeSpeed",
           "ChangeAltitude", "Action", "course_param_deg"]

CARROT_TYPE_MASK = 0x09F8
"""Use x, y, z and yaw; ignore velocity, acceleration and yaw rate."""


def course_param_deg(heading_enu_rad: float) -> float:
    """GUIDED_CHANGE_HEADING param2: the NED course in degrees, in [0, 360) even after rounding to float32."""
    degrees = math.degrees(ned_yaw_from_enu_heading(heading_enu_rad)) % 360.0
    return 0.0 if np.float32(degrees) >= 360.0 else degrees


@dataclass(frozen=True)
class Carrot:
    """SET_POSITION_TARGET_GLOBAL_INT: a point ahead on the commanded course."""

    lat_e7: int
    lon_e7: int
    altitude_m: float
    yaw_ned_rad: float
    time_boot_ms: int
    counter: ClassVar[str] = "carrots"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.set_position_target_global_int_encode(
            self.time_boot_ms, sysid, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, CARROT_TYPE_MASK,
            self.lat_e7, self.lon_e7, self.altitude_m, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self.yaw_ned_rad, 0.0)


@dataclass(frozen=True)
class ModeRequest:
    """COMMAND_LONG MAV_CMD_DO_SET_MODE with a custom mode (param2; PX4's main mode) and PX4's sub mode (param3)."""

    custom_mode: int
    sub_mode: int = 0
    counter: ClassVar[str] = "mode_requests"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.command_long_encode(sysid, 1, mavlink.MAV_CMD_DO_SET_MODE, 0,
                                       mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, self.custom_mode, self.sub_mode,
                                       0, 0, 0, 0)


@dataclass(frozen=True)
class Arm:
    """COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM, param1 1: arm."""

    counter: ClassVar[str] = "arm_requests"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.command_long_encode(sysid, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)


@dataclass(frozen=True)
class MessageInterval:
    """COMMAND_LONG MAV_CMD_SET_MESSAGE_INTERVAL: message id (param1), interval in microseconds (param2)."""

    message_id: int
    interval_us: float
    counter: ClassVar[str] = "stream_requests"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.command_long_encode(sysid, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                       self.message_id, self.interval_us, 0, 0, 0, 0, 0)


def _command_int(mav: mavlink.MAVLink, sysid: int, command: int, frame: int, p1: float, p2: float, p3: float,
                 z: float = 0.0):
    return mav.command_int_encode(sysid, 1, frame, command, 0, 0, p1, p2, p3, 0.0, 0, 0, z)


@dataclass(frozen=True)
class ChangeHeading:
    """COMMAND_INT MAV_CMD_GUIDED_CHANGE_HEADING: course over ground (param1 0), degrees NED, accel limit."""

    course_deg: float
    lateral_accel_mps2: float
    counter: ClassVar[str] = "heading_commands"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return _command_int(mav, sysid, mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, mavlink.MAV_FRAME_GLOBAL,
                            mavlink.HEADING_TYPE_COURSE_OVER_GROUND, self.course_deg, self.lateral_accel_mps2)


@dataclass(frozen=True)
class ChangeSpeed:
    """COMMAND_INT MAV_CMD_GUIDED_CHANGE_SPEED: airspeed (param1 0), m/s, fastest slew (param3 0)."""

    airspeed_mps: float
    counter: ClassVar[str] = "speed_commands"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return _command_int(mav, sysid, mavlink.MAV_CMD_GUIDED_CHANGE_SPEED, mavlink.MAV_FRAME_GLOBAL,
                            mavlink.SPEED_TYPE_AIRSPEED, self.airspeed_mps, 0.0)


@dataclass(frozen=True)
class ChangeAltitude:
    """COMMAND_INT MAV_CMD_GUIDED_CHANGE_ALTITUDE relative to home.

    Frame ``MAV_FRAME_GLOBAL_RELATIVE_ALT`` (3), the one relative frame every
    ArduPlane with this command accepts (older releases refuse the ``_INT`` 6).
    """

    altitude_m: float
    counter: ClassVar[str] = "altitude_commands"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return _command_int(mav, sysid, mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                            0.0, 0.0, 0.0, z=self.altitude_m)


Action = Carrot | ModeRequest | MessageInterval | Arm | ChangeHeading | ChangeSpeed | ChangeAltitude
