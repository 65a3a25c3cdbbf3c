"""The daemon's MAVLink side: vehicle telemetry in, heading commands out.

:class:`MavlinkCommander` is the imperative shell; the daemon loop calls it from
one thread (no callbacks): :meth:`~MavlinkCommander.poll` reads everything
waiting and updates one :class:`VehicleLink` per vehicle,
:meth:`~MavlinkCommander.command` records the wanted :class:`HeadingCommand`,
and :meth:`~MavlinkCommander.service` sends what is due. What is due is decided
by the pure :func:`due_actions` from the vehicle's link state and a
:class:`SendMemory` of what was sent, so the timing rules are testable without
sockets.

The encoding (reference/mavlink.md, "The encoding this project uses"):

* GCS HEARTBEAT (``MAV_TYPE_GCS``, ``MAV_AUTOPILOT_INVALID``, sysid 255) at 1 Hz
  on every link.
* For a vehicle with a command and a recent HEARTBEAT:

  - the carrot ``SET_POSITION_TARGET_GLOBAL_INT`` (frame
    ``GLOBAL_RELATIVE_ALT_INT``, type_mask ``0x09F8``) at ``carrot_rate_hz``:
    the latest position plus ``D`` metres along the commanded heading,
    ``D = max(3 V / omega_max, 15 s * V)`` (:func:`carrot_distance_m`),
    altitude the commanded one, yaw the commanded heading in NED;
  - ``MAV_CMD_DO_SET_MODE`` to GUIDED (ArduPilot numbering, custom mode 15;
    OFFBOARD for a PX4 peer) at most once per second until the HEARTBEAT
    shows it;
  - to an ArduPilot peer in GUIDED, ``COMMAND_INT MAV_CMD_GUIDED_CHANGE_HEADING``
    (course over ground, degrees NED in [0, 360), lateral acceleration limit
    ``V omega_max``) when the heading moved by more than 0.5 degree since the
    last one sent, and ``GUIDED_CHANGE_SPEED`` / ``GUIDED_CHANGE_ALTITUDE`` when
    those change; all three are sent again after the vehicle (re-)enters
    GUIDED or its link comes back.

Telemetry, converted at this edge (design.md section 3): GLOBAL_POSITION_INT
lat/lon -> ENU x, y through the scenario frame (origin = home), relative_alt ->
ENU z; NED velocity (cm/s) -> ENU m/s; ``hdg`` (or ATTITUDE.yaw) NED -> ENU heading.

Links: vehicles with the same connection string share one pymavlink connection
(e.g. ``udpin:127.0.0.1:14550`` where all simulated vehicles send from one
socket); messages are demultiplexed by source sysid. Messages from other
sysids are counted (``unknown_sysid``) and ignored, undecodable or badly signed
ones are counted (``bad_data``, ``bad_signature``). A ``udpin`` link has nobody
to write to until it hears a packet: such writes are counted (``no_destination``)
and dropped. With a signing key every link signs what it sends and rejects
unsigned messages (pymavlink ``setup_signing``).
"""

from __future__ import annotations

import logging
import math
import sys
from collections import Counter
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from gcs.adapters.mavlink_wire import (
    ARDUPLANE_MODE_NAMES,
    ARDUPLANE_MODES,
    GCS_SYSID,
    mavlink,
    ned_yaw_from_enu_heading,
    open_connection,
)
from gcs.core.geometry import LocalFrame, wrap_angle

__all__ = [
    "Carrot", "ChangeAltitude", "ChangeHeading", "ChangeSpeed", "HeadingCommand", "MavlinkCommander", "ModeRequest",
    "SendMemory", "VehicleLink", "carrot_distance_m", "course_param_deg", "due_actions", "in_guided_mode",
    "update_from_message",
]

log = logging.getLogger(__name__)

GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER
"""Our component id (190, as Mission Planner and MAVProxy use)."""
GUIDED = ARDUPLANE_MODES["GUIDED"]
PX4_OFFBOARD_MAIN_MODE = 6
"""PX4 main mode OFFBOARD: HEARTBEAT.custom_mode bits 16-23; DO_SET_MODE param2 (reference/mavlink.md)."""
CARROT_TYPE_MASK = 0x09F8
"""Use x, y, z and yaw; ignore velocity, acceleration and yaw rate."""
CARROT_LOOKAHEAD_S = 15.0
CARROT_TURN_RADII = 3.0
DEFAULT_MAX_TURN_RATE_RAD_S = 0.2
"""Turn-rate bound of a vehicle not given one (wang2012's UAVs)."""
MODE_REQUEST_PERIOD_S = 1.0
HEARTBEAT_PERIOD_S = 1.0
MAX_ABS_ALTITUDE_M = 100_000.0
"""Altitudes relative to home beyond this are not a fixed-wing's (telemetry rejected as ``bad_telemetry``)."""
HEADING_RESEND_RAD = math.radians(0.5)
AIRSPEED_RESEND_MPS = 0.1
ALTITUDE_RESEND_M = 0.5
MAX_MESSAGES_PER_POLL = 10_000
"""Bound on one poll's reading, so a flooded link cannot starve the daemon loop."""
_UNKNOWN_HDG = 65535


@dataclass(frozen=True)
class HeadingCommand:
    """What one vehicle is asked to fly: ENU heading (rad), altitude relative to home (m), airspeed (m/s)."""

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
    last_ack: dict[int, int] = field(default_factory=dict)
    """Result of the latest COMMAND_ACK per command id."""

    @property
    def mode_name(self) -> str:
        """ArduPlane name of the reported mode (the number for other autopilots)."""
        if self.custom_mode is None:
            return "unknown"
        if self.autopilot == mavlink.MAV_AUTOPILOT_PX4:
            return str(self.custom_mode)
        return ARDUPLANE_MODE_NAMES.get(self.custom_mode, str(self.custom_mode))

    def alive(self, now_s: float, timeout_s: float) -> bool:
        """A HEARTBEAT within ``timeout_s`` of ``now_s``."""
        return self.last_heartbeat_s is not None and now_s - self.last_heartbeat_s <= timeout_s


# ------------------------------------------------------------------ telemetry in


def update_from_message(link: VehicleLink, message, now_s: float, frame: LocalFrame) -> str | None:
    """Apply one message from the vehicle to ``link``; returns ``"heartbeat"`` for a vehicle HEARTBEAT and
    ``"bad_telemetry"`` for a position off the globe (or beyond :data:`MAX_ABS_ALTITUDE_M`), a heading out of
    range or a non-finite yaw, which change nothing (the caller counts them).

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
    elif kind == "ATTITUDE":
        if not math.isfinite(message.yaw):
            return "bad_telemetry"
        link.heading_enu_rad = ned_yaw_from_enu_heading(float(message.yaw))
    return None


def in_guided_mode(autopilot: int | None, custom_mode: int | None) -> bool:
    """Whether a HEARTBEAT's mode takes external guidance: PX4 OFFBOARD, else ArduPilot GUIDED (15)."""
    if custom_mode is None:
        return False
    if autopilot == mavlink.MAV_AUTOPILOT_PX4:
        return (custom_mode >> 16) & 0xFF == PX4_OFFBOARD_MAIN_MODE
    return custom_mode == GUIDED


# ------------------------------------------------------------------ commands out


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
    """SET_POSITION_TARGET_GLOBAL_INT: a point ahead on the commanded heading."""

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
    """COMMAND_LONG MAV_CMD_DO_SET_MODE with a custom mode (param2)."""

    custom_mode: int
    counter: ClassVar[str] = "mode_requests"

    def encode(self, mav: mavlink.MAVLink, sysid: int):
        return mav.command_long_encode(sysid, 1, mavlink.MAV_CMD_DO_SET_MODE, 0,
                                       mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, self.custom_mode, 0, 0, 0, 0, 0)


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


Action = Carrot | ModeRequest | ChangeHeading | ChangeSpeed | ChangeAltitude


@dataclass(frozen=True)
class SendMemory:
    """What was last sent to one vehicle (None: must be sent again)."""

    next_carrot_s: float = -math.inf
    mode_request_s: float = -math.inf
    heading_rad: float | None = None
    airspeed_mps: float | None = None
    altitude_m: float | None = None

    def forget_guided(self) -> SendMemory:
        """After a (re-)entry into GUIDED or a link's return: the GUIDED_CHANGE_* commands go out again."""
        return replace(self, heading_rad=None, airspeed_mps=None, altitude_m=None)


def _next_due(due_s: float, now_s: float, period_s: float) -> float:
    """The next firing of a periodic send: drift-free, but never a burst after a stall."""
    following = due_s + period_s
    return following if following > now_s else now_s + period_s


def carrot_for(frame: LocalFrame, link: VehicleLink, command: HeadingCommand, max_turn_rate_rad_s: float,
               now_s: float) -> Carrot:
    """The carrot from the latest position: ``D`` metres along the commanded heading, at the commanded altitude.

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


def due_actions(frame: LocalFrame, link: VehicleLink, memory: SendMemory, now_s: float, *,
                max_turn_rate_rad_s: float, carrot_period_s: float, link_timeout_s: float
                ) -> tuple[list[Action], SendMemory]:
    """What to send to one vehicle now, and the memory after sending it (pure).

    Nothing without a command or without a HEARTBEAT within ``link_timeout_s``.
    Otherwise, in order: the carrot when its period has elapsed (and a position
    is known); a mode request when the vehicle is not in GUIDED/OFFBOARD, at most
    one per ``MODE_REQUEST_PERIOD_S``; and, to an ArduPilot peer in GUIDED, the
    GUIDED_CHANGE_HEADING / _SPEED / _ALTITUDE whose value moved by more than
    0.5 degree / 0.1 m/s / 0.5 m since the last one sent.
    """
    command = link.command
    if command is None or not link.alive(now_s, link_timeout_s):
        return [], memory
    actions: list[Action] = []
    if link.position_enu_m is not None and now_s >= memory.next_carrot_s:
        actions.append(carrot_for(frame, link, command, max_turn_rate_rad_s, now_s))
        memory = replace(memory, next_carrot_s=_next_due(memory.next_carrot_s, now_s, carrot_period_s))
    if not in_guided_mode(link.autopilot, link.custom_mode):
        if now_s - memory.mode_request_s >= MODE_REQUEST_PERIOD_S:
            px4 = link.autopilot == mavlink.MAV_AUTOPILOT_PX4
            actions.append(ModeRequest(PX4_OFFBOARD_MAIN_MODE if px4 else GUIDED))
            memory = replace(memory, mode_request_s=now_s)
        return actions, memory
    if link.autopilot != mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA:
        return actions, memory
    if memory.heading_rad is None or abs(wrap_angle(command.heading_enu_rad - memory.heading_rad)) > HEADING_RESEND_RAD:
        actions.append(ChangeHeading(course_param_deg(command.heading_enu_rad),
                                     command.airspeed_mps * max_turn_rate_rad_s))
        memory = replace(memory, heading_rad=command.heading_enu_rad)
    if memory.airspeed_mps is None or abs(command.airspeed_mps - memory.airspeed_mps) > AIRSPEED_RESEND_MPS:
        actions.append(ChangeSpeed(command.airspeed_mps))
        memory = replace(memory, airspeed_mps=command.airspeed_mps)
    if memory.altitude_m is None or abs(command.altitude_m - memory.altitude_m) > ALTITUDE_RESEND_M:
        actions.append(ChangeAltitude(command.altitude_m))
        memory = replace(memory, altitude_m=command.altitude_m)
    return actions, memory


# ------------------------------------------------------------------ the shell


class _Link:
    """One pymavlink connection and the vehicles (sysid -> vehicle id) behind it."""

    def __init__(self, connection: str, vehicles: dict[int, str], signing_key: bytes | None, link_id: int) -> None:
        self.connection = connection
        self.vehicles = vehicles
        self.conn = open_connection(connection, source_system=GCS_SYSID, source_component=GCS_COMPONENT)
        if signing_key is not None:
            self.conn.setup_signing(signing_key, sign_outgoing=True, allow_unsigned_callback=None, link_id=link_id)
        self.next_heartbeat_s = -math.inf
        self.decode_error = sys.modules[type(self.conn.mav).__module__].MAVError  # the connection's dialect's

    def bound(self) -> str:
        """The connection string with the port the system bound where it listens (``udpin:127.0.0.1:0`` read
        back), else as given."""
        scheme, _, _ = self.connection.partition(":")
        sock = {"udpin": "port", "udp": "port", "tcpin": "listen"}.get(scheme)
        sock = getattr(self.conn, sock, None) if sock else None
        if sock is None:
            return self.connection
        host, port = sock.getsockname()[:2]
        return f"{scheme}:{host}:{port}"

    def has_destination(self) -> bool:
        """False for a ``udpin`` link that has not heard anyone yet (pymavlink sends to whom it heard)."""
        if not getattr(self.conn, "udp_server", False):
            return True
        return bool(getattr(self.conn, "clients", None) or getattr(self.conn, "last_address", None))


class MavlinkCommander:
    """Vehicle telemetry in and heading commands out, over one or more pymavlink links.

    Parameters
    ----------
    frame : LocalFrame
        The scenario's ENU frame; its origin is home (MAVLink altitudes are relative to it).
    roster : dict of vehicle id -> sysid
    connections : dict of vehicle id -> pymavlink connection string
        Vehicles with equal strings share one connection (``udpin:127.0.0.1:0`` too: one port the system
        chooses, :meth:`bound_connections` says which).
    signing_key : bytes or None
        32-byte MAVLink 2 signing key: sign outgoing, reject unsigned incoming.
    carrot_rate_hz : float
        Carrot re-send rate (2-5 Hz per reference/mavlink.md).
    max_turn_rate_rad_s : dict of vehicle id -> rad/s, or None
        For the carrot distance and the heading command's acceleration limit;
        ``DEFAULT_MAX_TURN_RATE_RAD_S`` for vehicles not listed.
    link_timeout_s : float
        A vehicle without HEARTBEAT for longer is not commanded; when it is heard
        again its link counts as having come back.
    """

    def __init__(self, frame: LocalFrame, roster: dict[str, int], connections: dict[str, str],
                 signing_key: bytes | None = None, carrot_rate_hz: float = 4.0,
                 max_turn_rate_rad_s: dict[str, float] | None = None, link_timeout_s: float = 5.0) -> None:
        if set(connections) != set(roster):
            raise ValueError(f"every vehicle needs one connection: roster {sorted(roster)}, "
                             f"connections {sorted(connections)}")
        if len(set(roster.values())) != len(roster) or not all(1 <= s <= 250 for s in roster.values()):
            raise ValueError(f"vehicle sysids must be distinct and in 1..250, got {roster}")
        if not carrot_rate_hz > 0:
            raise ValueError(f"carrot_rate_hz must be > 0, got {carrot_rate_hz}")
        if signing_key is not None and len(signing_key) != 32:
            raise ValueError("a MAVLink signing key is 32 bytes")
        self.frame = frame
        self.carrot_period_s = 1.0 / carrot_rate_hz
        self.link_timeout_s = link_timeout_s
        self.turn_rates = {vid: (max_turn_rate_rad_s or {}).get(vid, DEFAULT_MAX_TURN_RATE_RAD_S) for vid in roster}
        self._vehicles = {vid: VehicleLink(vid, sysid) for vid, sysid in roster.items()}
        self._memory = {vid: SendMemory() for vid in roster}
        self._up: set[str] = set()
        self._rejections: dict[tuple[str, int], int] = {}
        self._counters: Counter = Counter()
        groups: dict[str, dict[int, str]] = {}
        for vid, connection in connections.items():
            groups.setdefault(connection, {})[roster[vid]] = vid
        self._links: list[_Link] = []
        try:
            for link_id, (connection, vehicles) in enumerate(groups.items()):
                self._links.append(_Link(connection, vehicles, signing_key, link_id))
        except Exception:
            self.close()
            raise
        self._link_of = {vid: link for link in self._links for vid in link.vehicles.values()}

    # ---------------------------------------------------------------- queries

    def link(self, vehicle_id: str) -> VehicleLink:
        """The vehicle's MAVLink state (KeyError for a vehicle not in the roster)."""
        return self._vehicles[vehicle_id]

    def bound_connections(self) -> dict[str, str]:
        """Each vehicle's connection as bound (a listening port of 0 replaced by the one the system chose)."""
        return {vid: link.bound() for vid, link in self._link_of.items()}

    def alive(self, vehicle_id: str, now_s: float, timeout_s: float = 5.0) -> bool:
        """Whether the vehicle sent a HEARTBEAT within ``timeout_s`` of ``now_s``."""
        return self._vehicles[vehicle_id].alive(now_s, timeout_s)

    def counters(self) -> Counter:
        """Totals over every link and vehicle: sent, received, bad_data, unknown_sysid, carrots, ..."""
        return Counter(self._counters)

    def _count(self, key: str, vehicle: VehicleLink | None = None) -> None:
        self._counters[key] += 1
        if vehicle is not None:
            vehicle.counters[key] += 1

    # ---------------------------------------------------------------- input

    def poll(self, now_s: float) -> None:
        """Read every message waiting on every link (non-blocking) and update the vehicles."""
        for link in self._links:
            for _ in range(MAX_MESSAGES_PER_POLL):
                try:
                    message = link.conn.recv_msg()
                except (OSError, ValueError, link.decode_error) as error:
                    self._count("receive_errors")
                    log.debug("MAVLink receive on %s failed: %s", link.connection, error)
                    break
                if message is None:
                    break
                self._receive(link, message, now_s)

    def _receive(self, link: _Link, message, now_s: float) -> None:
        if message.get_type() == "BAD_DATA":
            self._count("bad_data")
            if "signature" in str(getattr(message, "reason", "")):
                self._count("bad_signature")
            return
        vehicle_id = link.vehicles.get(message.get_srcSystem())
        if vehicle_id is None:
            self._count("unknown_sysid")
            return
        vehicle = self._vehicles[vehicle_id]
        self._count("received", vehicle)
        if message.get_type() == "COMMAND_ACK":
            self._ack(vehicle, message)
            return
        was_up = vehicle.alive(now_s, self.link_timeout_s)
        was_guided = in_guided_mode(vehicle.autopilot, vehicle.custom_mode)
        outcome = update_from_message(vehicle, message, now_s, self.frame)
        if outcome == "bad_telemetry":
            self._count("bad_telemetry", vehicle)
            return
        if outcome != "heartbeat":
            return
        self._count("heartbeats", vehicle)
        if not was_up:
            self._count("link_up", vehicle)
            self._up.add(vehicle_id)
            log.info("%s (sysid %d) is up: autopilot %d, mode %s", vehicle_id, vehicle.sysid, vehicle.autopilot,
                     vehicle.mode_name)
        if not was_up or (not was_guided and in_guided_mode(vehicle.autopilot, vehicle.custom_mode)):
            self._memory[vehicle_id] = self._memory[vehicle_id].forget_guided()

    def _ack(self, vehicle: VehicleLink, message) -> None:
        if message.target_system not in (0, GCS_SYSID) or message.target_component not in (0, GCS_COMPONENT):
            return  # another ground station's command
        result = int(message.result)
        name = mavlink.enums["MAV_RESULT"][result].name if result in mavlink.enums["MAV_RESULT"] else str(result)
        self._count("ack_" + name.removeprefix("MAV_RESULT_").lower(), vehicle)
        vehicle.last_ack[int(message.command)] = result
        key = (vehicle.vehicle_id, int(message.command))
        if result in (mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_IN_PROGRESS):
            self._rejections.pop(key, None)
            return
        self._count("commands_rejected", vehicle)
        command = mavlink.enums["MAV_CMD"].get(message.command)
        level = logging.DEBUG if self._rejections.get(key) == result else logging.WARNING
        log.log(level, "%s rejected %s: %s", vehicle.vehicle_id, command.name if command else message.command, name)
        self._rejections[key] = result

    # ---------------------------------------------------------------- output

    def command(self, vehicle_id: str, cmd: HeadingCommand | None) -> None:
        """Remember the command wanted for a vehicle (None: stop commanding it)."""
        self._vehicles[vehicle_id].command = cmd

    def service(self, now_s: float) -> None:
        """Send what is due: GCS heartbeats, carrots, mode requests and GUIDED_CHANGE_* commands."""
        for link in self._links:
            if now_s >= link.next_heartbeat_s:
                link.next_heartbeat_s = _next_due(link.next_heartbeat_s, now_s, HEARTBEAT_PERIOD_S)
                heartbeat = link.conn.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                           mavlink.MAV_STATE_ACTIVE)
                self._send(link, heartbeat, "gcs_heartbeats")
        for vehicle_id, vehicle in self._vehicles.items():
            if vehicle_id in self._up and not vehicle.alive(now_s, self.link_timeout_s):
                self._up.discard(vehicle_id)
                self._count("link_lost", vehicle)
                log.warning("%s (sysid %d): no HEARTBEAT for %.1f s", vehicle_id, vehicle.sysid, self.link_timeout_s)
            actions, self._memory[vehicle_id] = due_actions(
                self.frame, vehicle, self._memory[vehicle_id], now_s, max_turn_rate_rad_s=self.turn_rates[vehicle_id],
                carrot_period_s=self.carrot_period_s, link_timeout_s=self.link_timeout_s)
            link = self._link_of[vehicle_id]
            for action in actions:
                self._send(link, action.encode(link.conn.mav, vehicle.sysid), action.counter, vehicle)

    def _send(self, link: _Link, message, counter: str, vehicle: VehicleLink | None = None) -> None:
        if not link.has_destination():
            self._count("no_destination", vehicle)
            return
        try:
            link.conn.mav.send(message)
        except OSError as error:
            self._count("send_errors", vehicle)
            log.debug("MAVLink send on %s failed: %s", link.connection, error)
            return
        self._count("sent", vehicle)
        self._count(counter, vehicle)

    def close(self) -> None:
        """Close every connection (idempotent)."""
        for link in self._links:
            link.conn.close()
        self._links = []
