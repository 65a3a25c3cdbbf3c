"""A scripted pilot on one MAVLink port of an ArduPlane SITL: what a person at a ground station would do by hand.

It waits for the autopilot, asks for telemetry rates, arms (ArduPlane refuses while its pre-arm
checks fail, for the first 10-20 s after boot: the pilot asks again every second), changes modes and
sends the guided commands, and keeps the latest of every message. Times are SITL's own
(``time_boot_ms``), so what is measured does not depend on how busy the machine is.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, ARDUPLANE_MODE_NAMES, mavlink, ned_yaw_from_enu_heading, \
    open_connection

__all__ = ["Pilot", "PilotError", "Sample"]

PILOT_SYSID, PILOT_COMPONENT = 250, 191
"""The pilot's own MAVLink address (a ground station's sysid other than the daemon's 255)."""


class PilotError(RuntimeError):
    """The autopilot did not do what it was asked within the time allowed (the message says what)."""


@dataclass(frozen=True)
class Sample:
    """One GLOBAL_POSITION_INT: SITL time (s), course over ground (ENU rad), ground speed (m/s), altitude above
    home (m), latitude and longitude (degrees), and the latest roll (rad)."""

    time_s: float
    course_rad: float
    speed_mps: float
    altitude_m: float
    lat_deg: float
    lon_deg: float
    roll_rad: float


class Pilot:
    """One MAVLink connection to one SITL vehicle (module docstring)."""

    def __init__(self, connection: str, sysid: int) -> None:
        self.sysid = sysid
        self.conn = open_connection(connection, PILOT_SYSID, PILOT_COMPONENT)
        self.latest: dict[str, object] = {}
        self.samples: list[Sample] = []
        self.recording = False

    def close(self) -> None:
        self.conn.close()

    # ------------------------------------------------------------ input

    def pump(self, seconds: float = 0.0) -> None:
        """Read what arrives for ``seconds`` of wall time (at least one pass)."""
        end = time.monotonic() + seconds
        while True:
            while (message := self.conn.recv_msg()) is not None:
                self._take(message)
            if time.monotonic() >= end:
                return
            time.sleep(0.005)

    def _take(self, message) -> None:
        if message.get_srcSystem() != self.sysid or message.get_srcComponent() != 1:
            return
        kind = message.get_type()
        self.latest[kind] = message
        if kind == "GLOBAL_POSITION_INT" and self.recording and message.lat != 0:
            attitude = self.latest.get("ATTITUDE")
            self.samples.append(Sample(
                message.time_boot_ms * 1e-3, math.atan2(message.vx, message.vy),
                math.hypot(message.vx, message.vy) * 1e-2, message.relative_alt * 1e-3, message.lat * 1e-7,
                message.lon * 1e-7, float(getattr(attitude, "roll", 0.0))))

    def wait_for(self, what: str, condition, timeout_s: float, every_s: float = 0.0, action=None) -> None:
        """Pump until ``condition()`` holds, calling ``action()`` every ``every_s`` meanwhile; PilotError after
        ``timeout_s`` naming ``what``."""
        deadline = time.monotonic() + timeout_s
        next_action = 0.0
        while not condition():
            now = time.monotonic()
            if now > deadline:
                raise PilotError(f"sysid {self.sysid}: {what} did not happen within {timeout_s:g} s")
            if action is not None and now >= next_action:
                action()
                next_action = now + every_s
            self.pump(0.02)

    # ------------------------------------------------------------ state

    @property
    def mode(self) -> str | None:
        heartbeat = self.latest.get("HEARTBEAT")
        return None if heartbeat is None else ARDUPLANE_MODE_NAMES.get(heartbeat.custom_mode, "?")

    @property
    def armed(self) -> bool:
        heartbeat = self.latest.get("HEARTBEAT")
        return heartbeat is not None and bool(heartbeat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    @property
    def altitude_m(self) -> float:
        position = self.latest.get("GLOBAL_POSITION_INT")
        return -math.inf if position is None else position.relative_alt * 1e-3

    @property
    def course_rad(self) -> float:
        """Course over ground, ENU radians (east 0, counter-clockwise)."""
        position = self.latest["GLOBAL_POSITION_INT"]
        return math.atan2(position.vx, position.vy)

    @property
    def boot_s(self) -> float:
        """SITL's time since boot, from the latest GLOBAL_POSITION_INT."""
        return self.latest["GLOBAL_POSITION_INT"].time_boot_ms * 1e-3

    # ------------------------------------------------------------ commands

    def command(self, command: int, *params: float) -> None:
        p = [*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0][:7]
        self.conn.mav.command_long_send(self.sysid, 1, command, 0, *p)

    def request_rate(self, message_id: int, hz: float) -> None:
        self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, message_id, 1e6 / hz)

    def set_mode(self, name: str) -> None:
        self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ARDUPLANE_MODES[name])

    def arm(self) -> None:
        self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def guided_course(self, course_enu_rad: float, accel_limit_mps2: float) -> None:
        """GUIDED_CHANGE_HEADING: course over ground (ENU radians), lateral acceleration limit (m/s^2)."""
        course_ned = math.degrees(ned_yaw_from_enu_heading(course_enu_rad)) % 360.0
        self.conn.mav.command_int_send(self.sysid, 1, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_GUIDED_CHANGE_HEADING,
                                       0, 0, mavlink.HEADING_TYPE_COURSE_OVER_GROUND, course_ned, accel_limit_mps2,
                                       0, 0, 0, 0)

    def guided_speed(self, airspeed_mps: float) -> None:
        self.conn.mav.command_int_send(self.sysid, 1, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_GUIDED_CHANGE_SPEED,
                                       0, 0, 0, airspeed_mps, 0, 0, 0, 0, 0)

    def guided_altitude(self, altitude_m: float) -> None:
        self.conn.mav.command_int_send(self.sysid, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                       mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, 0, 0, 0, 0, 0, 0, 0, 0, altitude_m)

    def reposition(self, lat_deg: float, lon_deg: float, altitude_m: float) -> None:
        """DO_REPOSITION (COMMAND_INT): fly to the point and circle it, in GUIDED."""
        self.conn.mav.command_int_send(self.sysid, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                       mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, math.nan,
                                       int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)), altitude_m)

    def take_off(self, altitude_m: float, timeout_s: float = 120.0) -> None:
        """Arm (asking every second while the pre-arm checks fail), TAKEOFF, and wait to be ``altitude_m`` up."""
        self.wait_for("arming", lambda: self.armed, timeout_s, every_s=1.0, action=self.arm)
        self.wait_for("TAKEOFF mode", lambda: self.mode == "TAKEOFF", 10.0, every_s=1.0,
                      action=lambda: self.set_mode("TAKEOFF"))
        self.wait_for(f"climbing to {altitude_m:g} m", lambda: self.altitude_m >= altitude_m, timeout_s)
