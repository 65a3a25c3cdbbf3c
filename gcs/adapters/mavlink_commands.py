"""What the daemon sends each vehicle, and when (pure): :func:`due_actions`.

The encoding (reference/mavlink.md, "The encoding this project uses"), chosen
from the autopilot the vehicle's HEARTBEAT names:

* to every vehicle with a recent HEARTBEAT, once its link is up and again every
  :data:`STREAM_CHECK_PERIOD_S` while a rate falls short:
  ``MAV_CMD_SET_MESSAGE_INTERVAL`` for GLOBAL_POSITION_INT and ATTITUDE at
  ``stream_rate_hz`` (ArduPlane streams them at 1 Hz until asked);
* for a vehicle with a command:

  - ``MAV_CMD_DO_SET_MODE`` to GUIDED (ArduPilot numbering, custom mode 15;
    OFFBOARD for a PX4 peer) at most once per second until the HEARTBEAT
    shows it, and only while the takeover guard allows (:class:`Takeover`:
    armed, and at least ``min_altitude_m`` above home); with ``takeoff``, a
    vehicle held back by the guard is armed (``MAV_CMD_COMPONENT_ARM_DISARM``)
    and switched to its own take-off mode (ArduPlane TAKEOFF, PX4
    AUTO.TAKEOFF), each at most once per second, until it is high enough;
  - to an ArduPilot peer in GUIDED, ``COMMAND_INT MAV_CMD_GUIDED_CHANGE_HEADING``
    (course over ground, degrees NED in [0, 360), lateral acceleration limit
    ``margin V omega_max``) when the course moved by more than 0.5 degree since
    the last one sent, and ``GUIDED_CHANGE_SPEED`` / ``GUIDED_CHANGE_ALTITUDE``
    when those change; all three are sent again after the vehicle (re-)enters
    GUIDED or its link comes back. No carrots: ArduPlane takes only their
    altitude (reference/mavlink.md);
  - to any other peer (PX4), the carrot ``SET_POSITION_TARGET_GLOBAL_INT``
    (frame ``GLOBAL_RELATIVE_ALT_INT``, type_mask ``0x09F8``) at
    ``carrot_rate_hz``: the latest position plus ``D`` metres along the commanded
    course, ``D = max(3 V / omega_max, 15 s * V)`` (:func:`carrot_distance_m`),
    altitude the commanded one, yaw the course in NED. It streams before
    the OFFBOARD request too, as PX4 requires;
* to a vehicle the daemon took over and lets go of (:meth:`SendMemory.let_go`:
  the daemon stops, or the target has been lost for long), one
  ``MAV_CMD_DO_SET_MODE`` to the hand-back mode, RTL or LOITER (PX4: AUTO.RTL,
  AUTO.LOITER), and nothing more until it is commanded again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from gcs.adapters.mavlink_link import (GUIDED, PX4_OFFBOARD_MAIN_MODE, STREAMED_TELEMETRY, HeadingCommand,
                                       VehicleLink, in_guided_mode)
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink, ned_yaw_from_enu_heading
from gcs.core.geometry import LocalFrame, wrap_angle

__all__ = [
    "Arm", "CARROT_TYPE_MASK", "Carrot", "ChangeAltitude", "ChangeHeading", "ChangeSpeed", "HANDBACK_MODES", "MessageInterval",
    "ModeRequest", "SendMemory", "Takeover", "handback_request", "takeoff_actions", "takeover_blocked", "carrot_distance_m", "next_due", "stream_requests", "carrot_for", "course_param_deg", "due_actions",
]

CARROT_TYPE_MASK = 0x09F8
"""Use x, y, z and yaw; ignore velocity, acceleration and yaw rate."""
CARROT_LOOKAHEAD_S = 15.0
CARROT_TURN_RADII = 3.0
DEFAULT_MAX_TURN_RATE_RAD_S = 0.2
"""Turn-rate bound of a vehicle not given one (wang2012's UAVs)."""
LATERAL_ACCEL_MARGIN = 1.25
"""GUIDED_CHANGE_HEADING's acceleration limit over ``V omega_max``: ArduPlane's bank limit is
``atan(a / g)``, so at exactly ``V omega_max`` a plan at full turn rate would leave no bank to
correct with; the turn rate asked is bounded by the steering itself (:mod:`gcs.core.steering`)."""
MODE_REQUEST_PERIOD_S = 1.0
HEADING_RESEND_RAD = math.radians(0.5)
AIRSPEED_RESEND_MPS = 0.1
ALTITUDE_RESEND_M = 0.5
DEFAULT_STREAM_RATE_HZ = 5.0
"""The rate asked for GLOBAL_POSITION_INT and ATTITUDE (``[daemon] stream_rate_hz``)."""
STREAM_CHECK_PERIOD_S = 5.0
"""How long after asking the arrival rates are checked, and how often after that."""
STREAM_ARRIVAL_FRACTION = 0.8
"""A stream arriving slower than this share of the rate asked is asked again (and counted)."""


def carrot_distance_m(speed_mps: float, max_turn_rate_rad_s: float) -> float:
    """How far ahead the carrot goes: ``D = max(3 R, 15 s V)`` with turn radius ``R = V / omega_max``.

    reference/mavlink.md asks for at least three turn radii and 10-20 s of flight,
    so that a vehicle never reaches (and loiters about) a carrot between sends.
    """
    return max(CARROT_TURN_RADII * speed_mps / max_turn_rate_rad_s, CARROT_LOOKAHEAD_S * speed_mps)


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


HANDBACK_MODES = ("LOITER", "RTL")
_HANDBACK_ARDUPILOT = {"LOITER": ModeRequest(ARDUPLANE_MODES["LOITER"]), "RTL": ModeRequest(ARDUPLANE_MODES["RTL"])}
_HANDBACK_PX4 = {"LOITER": ModeRequest(4, 3), "RTL": ModeRequest(4, 5)}
"""PX4's AUTO (main mode 4) with sub mode LOITER (3) or RTL (5)."""


@dataclass(frozen=True)
class Arm:
    """COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM, param1 1: arm."""

    counter: ClassVar[str] = "arm_requests"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.command_long_encode(sysid, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)


_TAKEOFF_ARDUPILOT = ModeRequest(ARDUPLANE_MODES["TAKEOFF"])
_TAKEOFF_PX4 = ModeRequest(4, 2)
"""PX4's AUTO (main mode 4) with sub mode TAKEOFF (2)."""


@dataclass(frozen=True)
class Takeover:
    """When the daemon may switch a vehicle to GUIDED/OFFBOARD, and the mode it gives it back in.

    A vehicle is taken over only when its HEARTBEAT says armed and its telemetry puts it at least
    ``min_altitude_m`` above home: the daemon never switches a plane on the ground, or one taking off.
    With ``takeoff`` it arms such a vehicle and puts it in its own take-off mode first (whose
    altitude, ArduPlane's TKOFF_ALT, must be above ``min_altitude_m``).
    """

    min_altitude_m: float = 30.0
    handback: str = "LOITER"
    takeoff: bool = False

    def __post_init__(self) -> None:
        if self.handback not in HANDBACK_MODES:
            raise ValueError(f"hand-back mode {self.handback!r}; expected one of {', '.join(HANDBACK_MODES)}")
        if not math.isfinite(self.min_altitude_m):
            raise ValueError(f"takeover altitude must be finite, got {self.min_altitude_m}")


def takeover_blocked(link: VehicleLink, takeover: Takeover) -> str | None:
    """Why the vehicle may not be switched to GUIDED now (``disarmed``, ``no position``, ``below N m``), or None."""
    if not link.armed:
        return "disarmed"
    if link.position_enu_m is None:
        return "no position"
    if link.position_enu_m[2] < takeover.min_altitude_m:
        return f"below {takeover.min_altitude_m:g} m"
    return None


def _in_takeoff_mode(link: VehicleLink) -> bool:
    """The HEARTBEAT shows the take-off mode (PX4: main mode in bits 16-23, sub mode in bits 24-31)."""
    if link.autopilot == mavlink.MAV_AUTOPILOT_PX4:
        return link.custom_mode == (_TAKEOFF_PX4.custom_mode << 16 | _TAKEOFF_PX4.sub_mode << 24)
    return link.custom_mode == _TAKEOFF_ARDUPILOT.custom_mode


def takeoff_actions(link: VehicleLink, memory: SendMemory, now_s: float) -> tuple[list[Action], SendMemory, str]:
    """Arm a disarmed vehicle, then ask for its take-off mode, each at most once per
    :data:`MODE_REQUEST_PERIOD_S`; and what the vehicle is waiting for (``arming``, ``taking off``)."""
    if link.armed and _in_takeoff_mode(link):
        return [], memory, "taking off"
    waiting = "taking off" if link.armed else "arming"
    if now_s - memory.mode_request_s < MODE_REQUEST_PERIOD_S:
        return [], memory, waiting
    if not link.armed:
        action: Action = Arm()
    else:
        action = _TAKEOFF_PX4 if link.autopilot == mavlink.MAV_AUTOPILOT_PX4 else _TAKEOFF_ARDUPILOT
    return [action], replace(memory, mode_request_s=now_s), waiting


def handback_request(autopilot: int | None, mode: str) -> ModeRequest:
    """The DO_SET_MODE that gives a vehicle back in ``mode`` (one of :data:`HANDBACK_MODES`)."""
    table = _HANDBACK_PX4 if autopilot == mavlink.MAV_AUTOPILOT_PX4 else _HANDBACK_ARDUPILOT
    return table[mode]


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


@dataclass(frozen=True)
class SendMemory:
    """What was last sent to one vehicle (None: must be sent again), and the last check of its streams."""

    next_carrot_s: float = -math.inf
    mode_request_s: float = -math.inf
    heading_rad: float | None = None
    airspeed_mps: float | None = None
    altitude_m: float | None = None
    streams_asked_s: float | None = None
    arrivals_when_asked: tuple[int, ...] = ()
    stream_rates_hz: tuple[float, ...] | None = None
    """The arrival rates of :data:`STREAMED_TELEMETRY` measured at the last check (None before one)."""
    took_over: bool = False
    """The vehicle was seen in GUIDED/OFFBOARD while the daemon commanded it."""
    handback_due: bool = False
    blocked: str | None = None
    """Why the last mode request was held back (:func:`takeover_blocked`), None when it was not."""

    def let_go(self) -> SendMemory:
        """The daemon lets go of the vehicle: the hand-back mode is asked once if it had taken it over."""
        return replace(self, handback_due=self.took_over, took_over=False)

    def forget_guided(self) -> SendMemory:
        """After a (re-)entry into GUIDED or a link's return: the GUIDED_CHANGE_* commands go out again."""
        return replace(self, heading_rad=None, airspeed_mps=None, altitude_m=None)

    def forget_streams(self) -> SendMemory:
        """After a link's return: the stream rates are asked for again."""
        return replace(self, streams_asked_s=None, arrivals_when_asked=(), stream_rates_hz=None)


def next_due(due_s: float, now_s: float, period_s: float) -> float:
    """The next firing of a periodic send: drift-free, but never a burst after a stall."""
    following = due_s + period_s
    return following if following > now_s else now_s + period_s


def carrot_for(frame: LocalFrame, link: VehicleLink, command: HeadingCommand, max_turn_rate_rad_s: float,
               now_s: float) -> Carrot:
    """The carrot from the latest position: ``D`` metres along the commanded course, at the commanded altitude.

    ``V`` in ``D`` is the larger of the commanded airspeed and the measured ground speed.
    """
    assert link.position_enu_m is not None
    speed = command.airspeed_mps
    if link.velocity_enu_mps is not None:
        speed = max(speed, float(np.hypot(link.velocity_enu_mps[0], link.velocity_enu_mps[1])))
    distance = carrot_distance_m(speed, max_turn_rate_rad_s)
    heading = command.heading_enu_rad
    east, north = link.position_enu_m[0], link.position_enu_m[1]
    ahead = [east + distance * math.cos(heading), north + distance * math.sin(heading), command.altitude_m]
    lat, lon, _ = frame.to_geodetic(ahead)
    return Carrot(int(round(float(lat) * 1e7)), int(round(float(lon) * 1e7)), command.altitude_m,
                  ned_yaw_from_enu_heading(heading), int(now_s * 1000.0) & 0xFFFFFFFF)


def stream_requests(link: VehicleLink, memory: SendMemory, now_s: float, rate_hz: float
                    ) -> tuple[list[Action], SendMemory]:
    """The SET_MESSAGE_INTERVAL requests due: at once for a new link, then again at each
    :data:`STREAM_CHECK_PERIOD_S` check that finds a stream below :data:`STREAM_ARRIVAL_FRACTION` of
    ``rate_hz`` (measured since the previous check, on the clock of ``now_s``)."""
    if memory.streams_asked_s is not None and now_s - memory.streams_asked_s < STREAM_CHECK_PERIOD_S:
        return [], memory  # between two checks (every pass of the daemon's loop): nothing to build
    counts = tuple(link.arrivals[name] for name in STREAMED_TELEMETRY)
    requests: list[Action] = [MessageInterval(message_id, 1e6 / rate_hz) for message_id in STREAMED_TELEMETRY.values()]
    if memory.streams_asked_s is None:
        return requests, replace(memory, streams_asked_s=now_s, arrivals_when_asked=counts)
    elapsed = now_s - memory.streams_asked_s
    rates = tuple((now - before) / elapsed for now, before in zip(counts, memory.arrivals_when_asked))
    memory = replace(memory, streams_asked_s=now_s, arrivals_when_asked=counts, stream_rates_hz=rates)
    if min(rates) < STREAM_ARRIVAL_FRACTION * rate_hz:
        return requests, memory
    return [], memory


def due_actions(frame: LocalFrame, link: VehicleLink, memory: SendMemory, now_s: float, *,
                max_turn_rate_rad_s: float, carrot_period_s: float, link_timeout_s: float,
                stream_rate_hz: float = DEFAULT_STREAM_RATE_HZ, takeover: Takeover = Takeover()
                ) -> tuple[list[Action], SendMemory]:
    """What to send to one vehicle now, and the memory after sending it (pure).

    Nothing without a HEARTBEAT within ``link_timeout_s``. Then, in order: the
    stream-rate requests that are due (:func:`stream_requests`; none with
    ``stream_rate_hz`` 0); the hand-back request when one is due; nothing more
    without a command; for a peer that is not ArduPilot, the carrot when its
    period has elapsed (and a position is known); a mode request when the
    vehicle is not in GUIDED/OFFBOARD and the takeover guard allows it, at most
    one per ``MODE_REQUEST_PERIOD_S``; and, to an ArduPilot peer in GUIDED, the
    GUIDED_CHANGE_HEADING / _SPEED / _ALTITUDE whose value moved by more than
    0.5 degree / 0.1 m/s / 0.5 m since the last one sent.
    """
    if not link.alive(now_s, link_timeout_s):
        return [], memory
    actions: list[Action] = []
    if stream_rate_hz > 0:
        actions, memory = stream_requests(link, memory, now_s, stream_rate_hz)
    if memory.handback_due:
        actions.append(handback_request(link.autopilot, takeover.handback))
        memory = replace(memory, handback_due=False)
    command = link.command
    if command is None:
        return actions, memory
    if not link.is_ardupilot and link.position_enu_m is not None and now_s >= memory.next_carrot_s:
        actions.append(carrot_for(frame, link, command, max_turn_rate_rad_s, now_s))
        memory = replace(memory, next_carrot_s=next_due(memory.next_carrot_s, now_s, carrot_period_s))
    if not in_guided_mode(link.autopilot, link.custom_mode):
        blocked = takeover_blocked(link, takeover)
        if blocked is not None and takeover.takeoff and blocked != "no position":
            more, memory, blocked = takeoff_actions(link, memory, now_s)
            actions += more
        if blocked is not None:
            return actions, replace(memory, blocked=blocked)
        if now_s - memory.mode_request_s >= MODE_REQUEST_PERIOD_S:
            px4 = link.autopilot == mavlink.MAV_AUTOPILOT_PX4
            actions.append(ModeRequest(PX4_OFFBOARD_MAIN_MODE if px4 else GUIDED))
            memory = replace(memory, mode_request_s=now_s, blocked=None)
        return actions, memory
    if not memory.took_over or memory.blocked is not None:
        memory = replace(memory, took_over=True, blocked=None)
    if not link.is_ardupilot:
        return actions, memory
    if memory.heading_rad is None or abs(wrap_angle(command.heading_enu_rad - memory.heading_rad)) > HEADING_RESEND_RAD:
        actions.append(ChangeHeading(course_param_deg(command.heading_enu_rad),
                                     LATERAL_ACCEL_MARGIN * command.airspeed_mps * max_turn_rate_rad_s))
        memory = replace(memory, heading_rad=command.heading_enu_rad)
    if memory.airspeed_mps is None or abs(command.airspeed_mps - memory.airspeed_mps) > AIRSPEED_RESEND_MPS:
        actions.append(ChangeSpeed(command.airspeed_mps))
        memory = replace(memory, airspeed_mps=command.airspeed_mps)
    if memory.altitude_m is None or abs(command.altitude_m - memory.altitude_m) > ALTITUDE_RESEND_M:
        actions.append(ChangeAltitude(command.altitude_m))
        memory = replace(memory, altitude_m=command.altitude_m)
    return actions, memory
