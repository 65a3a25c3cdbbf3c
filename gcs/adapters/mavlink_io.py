"""The daemon's MAVLink side: the shell around vehicle telemetry in and commands out.

:class:`MavlinkCommander` is the imperative shell; the daemon loop calls it from
one thread (no callbacks): :meth:`~MavlinkCommander.poll` reads everything
waiting and updates one :class:`~gcs.adapters.mavlink_link.VehicleLink` per
vehicle (:func:`~gcs.adapters.mavlink_link.update_from_message`),
:meth:`~MavlinkCommander.command` records the wanted
:class:`~gcs.adapters.mavlink_link.HeadingCommand`, and
:meth:`~MavlinkCommander.service` sends what is due. What is due is decided
by the pure :func:`~gcs.adapters.mavlink_commands.due_actions` (whose
docstring gives the encoding) from the vehicle's link state and a
:class:`~gcs.adapters.mavlink_commands.SendMemory` of what was sent, so the
timing rules are testable without sockets. A GCS HEARTBEAT (``MAV_TYPE_GCS``,
``MAV_AUTOPILOT_INVALID``, sysid 255) goes out at 1 Hz on every link.

Links: vehicles with the same connection string share one pymavlink connection
(e.g. ``udpin:127.0.0.1:14550`` where all simulated vehicles send from one
socket); messages are demultiplexed by source sysid. Messages from other
sysids are counted (``unknown_sysid``) and ignored, undecodable or badly signed
ones are counted (``bad_data``, ``bad_signature``). A ``udpin`` link has nobody
to write to until it hears a packet: such writes are counted (``no_destination``)
and dropped. With a signing key every link signs what it sends and rejects
unsigned messages (pymavlink ``setup_signing``). A stream that arrives slower
than asked is counted (``streams_below_rate``) and logged.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections import Counter

from gcs.adapters.mavlink_commands import (DEFAULT_MAX_TURN_RATE_RAD_S, DEFAULT_STREAM_RATE_HZ,
                                           STREAM_ARRIVAL_FRACTION, SendMemory, due_actions, next_due)
from gcs.adapters.mavlink_takeover import Takeover
from gcs.adapters.mavlink_link import STREAMED_TELEMETRY, HeadingCommand, VehicleLink, in_guided_mode, update_from_message
from gcs.adapters.mavlink_wire import GCS_SYSID, mavlink, open_connection
from gcs.core.geometry import LocalFrame

__all__ = ["HeadingCommand", "MavlinkCommander"]

log = logging.getLogger(__name__)

GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER
"""Our component id (190, as Mission Planner and MAVProxy use)."""
HEARTBEAT_PERIOD_S = 1.0
MAX_MESSAGES_PER_POLL = 10_000
"""Bound on one poll's reading, so a flooded link cannot starve the daemon loop."""



HANDBACK_ANSWER_S = 2.0
SILENT_S = 0.5
"""While the stopping daemon waits for hand-back answers, a vehicle not heard from for this long is not waited for."""
"""How long a stopping daemon waits for the vehicles it hands back to answer (:meth:`MavlinkCommander.hand_back_before_closing`)."""

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
        Carrot re-send rate (2-5 Hz: PX4 leaves OFFBOARD 1 s after the last; docs/mavlink.md).
    max_turn_rate_rad_s : dict of vehicle id -> rad/s, or None
        For the carrot distance and the heading command's acceleration limit;
        ``DEFAULT_MAX_TURN_RATE_RAD_S`` for vehicles not listed.
    link_timeout_s : float
        A vehicle without HEARTBEAT for longer is not commanded; when it is heard
        again its link counts as having come back.
    stream_rate_hz : float
        The rate asked of every vehicle for GLOBAL_POSITION_INT and ATTITUDE (0: ask nothing).
    takeover : Takeover
        When a vehicle may be switched to GUIDED/OFFBOARD, and the mode :meth:`let_go` gives it back in.
    """

    def __init__(self, frame: LocalFrame, roster: dict[str, int], connections: dict[str, str],
                 signing_key: bytes | None = None, carrot_rate_hz: float = 4.0,
                 max_turn_rate_rad_s: dict[str, float] | None = None, link_timeout_s: float = 5.0,
                 stream_rate_hz: float = DEFAULT_STREAM_RATE_HZ, takeover: Takeover = Takeover()) -> None:
        if set(connections) != set(roster):
            raise ValueError(f"every vehicle needs one connection: roster {sorted(roster)}, "
                             f"connections {sorted(connections)}")
        if len(set(roster.values())) != len(roster) or not all(1 <= s <= 250 for s in roster.values()):
            raise ValueError(f"vehicle sysids must be distinct and in 1..250, got {roster}")
        if not carrot_rate_hz > 0:
            raise ValueError(f"carrot_rate_hz must be > 0, got {carrot_rate_hz}")
        if signing_key is not None and len(signing_key) != 32:
            raise ValueError("a MAVLink signing key is 32 bytes")
        if not (math.isfinite(stream_rate_hz) and stream_rate_hz >= 0):
            raise ValueError(f"stream_rate_hz must be >= 0, got {stream_rate_hz}")
        self.frame = frame
        self.stream_rate_hz = stream_rate_hz
        self.takeover = takeover
        self._released: dict[str, str] = {}
        self._handing_back: set[str] = set()
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

    def connection(self, vehicle_id: str):
        """The pymavlink connection the vehicle is reached through (shared by the vehicles of one link)."""
        return self._link_of[vehicle_id].conn

    def bound_connections(self) -> dict[str, str]:
        """Each vehicle's connection as bound (a listening port of 0 replaced by the one the system chose)."""
        return {vid: link.bound() for vid, link in self._link_of.items()}

    def alive(self, vehicle_id: str, now_s: float, timeout_s: float = 5.0) -> bool:
        """Whether the vehicle sent a HEARTBEAT within ``timeout_s`` of ``now_s``."""
        return self._vehicles[vehicle_id].alive(now_s, timeout_s)

    def control(self, vehicle_id: str, now_s: float) -> str:
        """Who flies the vehicle: ``daemon`` (in GUIDED/OFFBOARD, commanded), ``waiting: REASON`` (commanded but
        held back by the takeover guard), ``switching`` (asked for GUIDED), ``handed back: WHY`` or ``pilot``."""
        link, memory = self._vehicles[vehicle_id], self._memory[vehicle_id]
        if link.command is None:
            released = self._released.get(vehicle_id)
            return f"handed back: {released}" if released else "pilot"
        if in_guided_mode(link.autopilot, link.custom_mode):
            return "daemon"
        return f"waiting: {memory.blocked}" if memory.blocked else "switching"

    def let_go(self, vehicle_id: str, why: str) -> None:
        """Stop commanding the vehicle and, if the daemon took it over, give it back in the hand-back mode (sent
        by the next :meth:`service`). Commanding it again takes it over again (through the guard)."""
        link = self._vehicles[vehicle_id]
        if link.command is None and vehicle_id in self._released:
            return
        memory = self._memory[vehicle_id]
        link.command = None
        self._memory[vehicle_id] = memory.let_go()
        self._released[vehicle_id] = why
        if memory.took_over:
            self._count("handbacks", link)
            self._handing_back.add(vehicle_id)
            link.last_ack.pop(mavlink.MAV_CMD_DO_SET_MODE, None)
            log.info("%s: handed back in %s (%s)", vehicle_id, self.takeover.handback, why)

    def hand_back_before_closing(self, now_s: float, timeout_s: float = HANDBACK_ANSWER_S) -> None:
        """Send what is due at ``now_s`` (the hand-backs of :meth:`let_go`) and wait, at most ``timeout_s`` of wall
        time, for each vehicle being handed back to answer its mode request, while it is still heard from: an
        autopilot may drop what is still in its input buffer when the connection closes (ArduPilot SITL's TCP
        ports do), and the hand-back must reach it. A vehicle not heard from for :data:`SILENT_S` (gone
        already, or a simulator that has ended) is not waited for."""
        self.service(now_s)
        waiting = [vid for vid in self._handing_back if self._vehicles[vid].alive(now_s, self.link_timeout_s)]
        start = time.monotonic()
        while (elapsed := time.monotonic() - start) < timeout_s:
            self.poll(now_s + elapsed)
            waiting = [vid for vid in waiting if mavlink.MAV_CMD_DO_SET_MODE not in self._vehicles[vid].last_ack
                       and (elapsed < SILENT_S or self._vehicles[vid].heard_since(now_s + elapsed - SILENT_S))]
            if not waiting:
                return
            time.sleep(0.01)
        log.warning("no answer to the hand-back from %s within %g s", ", ".join(sorted(waiting)), timeout_s)

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
        if outcome == "no_fix":
            self._count("positions_without_fix", vehicle)
            if vehicle.counters["positions_without_fix"] == 1:
                log.info("%s: positions at lat 0, lon 0 (no GPS fix yet) are dropped until it has a fix",
                         vehicle_id)
            return
        if outcome != "heartbeat":
            return
        self._count("heartbeats", vehicle)
        if not was_up:
            self._count("link_up", vehicle)
            self._up.add(vehicle_id)
            log.info("%s (sysid %d) is up: autopilot %d, mode %s", vehicle_id, vehicle.sysid, vehicle.autopilot,
                     vehicle.mode_name)
        if not was_up:
            self._memory[vehicle_id] = self._memory[vehicle_id].forget_streams()
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
        """Remember the command wanted for a vehicle (None: stop commanding it, leaving its mode as it is)."""
        self._vehicles[vehicle_id].command = cmd
        if cmd is not None:
            self._released.pop(vehicle_id, None)

    def service(self, now_s: float) -> None:
        """Send what is due: GCS heartbeats, carrots, mode requests and GUIDED_CHANGE_* commands."""
        for link in self._links:
            if now_s >= link.next_heartbeat_s:
                link.next_heartbeat_s = next_due(link.next_heartbeat_s, now_s, HEARTBEAT_PERIOD_S)
                heartbeat = link.conn.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                           mavlink.MAV_STATE_ACTIVE)
                self._send(link, heartbeat, "gcs_heartbeats")
        for vehicle_id, vehicle in self._vehicles.items():
            if vehicle_id in self._up and not vehicle.alive(now_s, self.link_timeout_s):
                self._up.discard(vehicle_id)
                self._count("link_lost", vehicle)
                log.warning("%s (sysid %d): no HEARTBEAT for %.1f s", vehicle_id, vehicle.sysid, self.link_timeout_s)
            before = self._memory[vehicle_id]
            actions, after = due_actions(
                self.frame, vehicle, before, now_s, max_turn_rate_rad_s=self.turn_rates[vehicle_id],
                carrot_period_s=self.carrot_period_s, link_timeout_s=self.link_timeout_s,
                stream_rate_hz=self.stream_rate_hz, takeover=self.takeover)
            self._memory[vehicle_id] = after
            if after.stream_rates_hz is not None and after.stream_rates_hz is not before.stream_rates_hz:
                self._check_streams(vehicle, after.stream_rates_hz)
            if after.blocked != before.blocked and after.blocked is not None:
                self._count("takeover_held", vehicle)
                log.warning("%s: not switched to GUIDED: %s", vehicle_id, after.blocked)
            if after.took_over and not before.took_over:
                log.info("%s: taken over in %s", vehicle_id, vehicle.mode_name)
            link = self._link_of[vehicle_id]
            for action in actions:
                self._send(link, action.encode(link.conn.mav, vehicle.sysid), action.counter, vehicle)

    def stream_rates(self, vehicle_id: str) -> dict[str, float] | None:
        """The arrival rate of each stream asked for, measured at the last check (None before one)."""
        rates = self._memory[vehicle_id].stream_rates_hz
        return None if rates is None else dict(zip(STREAMED_TELEMETRY, rates))

    def _check_streams(self, vehicle: VehicleLink, rates: tuple[float, ...]) -> None:
        slow = {name: rate for name, rate in zip(STREAMED_TELEMETRY, rates)
                if rate < STREAM_ARRIVAL_FRACTION * self.stream_rate_hz}
        if slow:
            self._count("streams_below_rate", vehicle)
            log.warning("%s: %s arriving below the %.1f Hz asked; asking again", vehicle.vehicle_id,
                        ", ".join(f"{name} at {rate:.1f} Hz" for name, rate in slow.items()), self.stream_rate_hz)

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
