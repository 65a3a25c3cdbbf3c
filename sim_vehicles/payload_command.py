"""``sim-vehicles payload``: the payload bridge's shell (MAVLink in, Zenoh out) and its command line.

Per ``--vehicle ID=CONNECTION`` the bridge reads that vehicle's autopilot as a passive
MAVLink reader: a MAVProxy ``--out`` (``udpin:127.0.0.1:14551`` with ``mavproxy.py
--out=udpout:127.0.0.1:14551``) or a second autopilot port (ArduPilot SITL's
``tcp:127.0.0.1:5762``, PX4's ``udpin:127.0.0.1:14540``), so that the daemon keeps its
own link. Vehicles given the same connection share one socket, demultiplexed by the
scenario's sysid (component 1); other systems are ignored. It sends nothing, unless
``--request-rate HZ`` asks the autopilot for GLOBAL_POSITION_INT, ATTITUDE and
GPS_RAW_INT at HZ (SET_MESSAGE_INTERVAL, which ArduPilot and PX4 take, and
REQUEST_DATA_STREAM for ArduPilot's stream groups), once when the vehicle is first
heard and again each time its telemetry comes back after going stale: for an
autopilot that streams slower than the scenario's ``nav_rate_hz`` (ArduPlane's 1 Hz
until a ground station asks). An autopilot keeps such a rate for the whole port,
so a daemon that shares it through MAVProxy gets it too. It never commands the vehicle.

What it publishes, and on which clock: :mod:`sim_vehicles.payload`. Stop with
Ctrl-C (SIGINT) or SIGTERM; ``--duration S`` stops after S wall seconds. The summary
prints one line per vehicle.
"""

from __future__ import annotations

import argparse
import logging
import select
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import zenoh

from gcs.adapters.mavlink_wire import GCS_SYSID, check_connection, mavlink, open_connection
from gcs.adapters.zenoh_session import (DEFAULT_ENDPOINT, ZenohSettings, add_zenoh_arguments, open_session, publish,
                                        required_settings)
from gcs.cli_errors import UsageError, one_line, positive, set_command, stop_on_signals
from gcs.config.world import build_world
from gcs.scenarios import load_scenario, scenario_base_dir
from protocols.errors import ProtocolError
from protocols.keys import alive_key, validate_prefix
from sim_vehicles.payload import Liveliness, PayloadBridge, Publication, summary_line
from sim_vehicles.run_command import add_scenario_argument
from sim_vehicles.zenoh_out import ScenarioAnnouncer, close_zenoh, declare_vehicle_publishers

if TYPE_CHECKING:  # pymavlink has no type information: a link checks as Any
    from pymavlink.mavutil import mavfile

__all__ = ["add_payload", "check_payload", "PayloadRunner", "BRIDGE_COMPONENT", "TELEMETRY"]

log = logging.getLogger(__name__)

BRIDGE_COMPONENT = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER
"""The bridge's MAVLink component (system 255), seen only in its stream-rate requests."""
TELEMETRY = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: mavlink.MAV_DATA_STREAM_POSITION,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: mavlink.MAV_DATA_STREAM_EXTRA1,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: mavlink.MAV_DATA_STREAM_EXTENDED_STATUS,
}
"""The messages the bridge reads, with the ArduPilot stream group that carries each."""
_AUTOPILOT_COMPONENT = 1
_POLL_S = 0.01
"""Longest wait for telemetry between two looks at the clock (wall seconds)."""
_MAX_READ = 1000
"""Messages read from one link before the clock is looked at again."""


@dataclass(frozen=True)
class PayloadOptions:
    """How to run the bridge: each vehicle's connection, Zenoh, prefix, duration (wall s, None: until stopped),
    the stream rate to ask for (None: ask nothing)."""

    connections: dict[str, str]
    zenoh: ZenohSettings
    prefix: str = "gcs"
    duration_s: float | None = None
    request_rate_hz: float | None = None


class PayloadRunner:
    """Reads the vehicles' MAVLink, feeds :class:`PayloadBridge`, publishes what it returns over Zenoh."""

    def __init__(self, bridge: PayloadBridge, options: PayloadOptions,
                 clock: Callable[[], float] = time.monotonic, wall_clock: Callable[[], int] = time.time_ns) -> None:
        self.bridge, self.options, self.clock, self.wall_clock = bridge, options, clock, wall_clock
        self.stop_event = threading.Event()
        self.sysids = {v.id: v.sysid for v in bridge.scenario.vehicles if v.id in bridge.vehicles}
        self._by_sysid: dict[str, dict[int, str]] = {}
        """Per connection string, the vehicles it carries by sysid."""
        for vehicle_id, connection in options.connections.items():
            self._by_sysid.setdefault(connection, {})[self.sysids[vehicle_id]] = vehicle_id
        self.links: dict[str, mavfile] = {}
        self.session: zenoh.Session | None = None
        self.publishers: dict[tuple[str, str], zenoh.Publisher] = {}
        self.tokens: dict[str, zenoh.LivelinessToken] = {}
        self.counters: Counter = Counter()
        self.opened = threading.Event()
        """Set once the links and the Zenoh session are open (tests wait on it)."""
        self._requested: set[str] = set()
        self._connects: dict[str, int | None] = {}
        self._start = 0.0
        self.announcer = ScenarioAnnouncer(bridge.scenario)

    def stop(self) -> None:
        """Ask the loop to finish (thread-safe; signal handlers call it)."""
        self.stop_event.set()

    def run(self) -> None:
        """Run until ``duration_s`` or :meth:`stop`; always closes what it opened."""
        try:
            self._open()
            self._loop()
        finally:
            self.close()

    def _open(self) -> None:
        for connection in sorted(set(self.options.connections.values())):
            self.links[connection] = open_connection(connection, GCS_SYSID, BRIDGE_COMPONENT)
        log.info("MAVLink: %s", ", ".join(f"{vid} (sysid {self.sysids[vid]}) <- {c}{self._bound(c)}"
                                          for vid, c in self.options.connections.items()))
        session = self.session = open_session(self.options.zenoh)
        self.publishers = declare_vehicle_publishers(session, self.bridge.vehicles, self.options.prefix,
                                                     [t.id for t in self.bridge.scenario.all_targets])
        log.info("Zenoh: %s session, prefix %r", self.options.zenoh.mode, self.options.prefix)
        self.opened.set()

    def _bound(self, connection: str) -> str:
        """`` (listening on HOST:PORT)`` for a link that listens (a port of 0 read back), else ``""``."""
        if not connection.startswith(("udpin:", "udp:", "tcpin:")):
            return ""
        try:
            host, port = self.links[connection].port.getsockname()[:2]
        except (AttributeError, OSError):
            return ""
        return f" (listening on {host}:{port})"

    def close(self) -> None:
        """Withdraw the tokens, close the Zenoh session and the MAVLink links."""
        close_zenoh(self.tokens.values(), self.publishers, self.session)
        self.tokens.clear()
        self.session = None
        for link in self.links.values():
            link.close()
        self.links.clear()

    def summary_lines(self) -> list[str]:
        """One line per vehicle, then the link counters."""
        lines = [summary_line(vid, counts) for vid, counts in self.bridge.counts.items()]
        if self.counters:
            lines.append("  MAVLink: " + ", ".join(f"{k} {v}" for k, v in sorted(self.counters.items())))
        return lines

    def _loop(self) -> None:
        self._start = self.clock()
        self.bridge.start(self.wall_clock())
        duration = self.options.duration_s
        while not self.stop_event.is_set():
            now = self.clock() - self._start
            if duration is not None and now >= duration:
                break
            self._receive(now)
            for action in self.bridge.advance(self.clock() - self._start):
                self._apply(action)
            self._wait(_POLL_S)

    def _wait(self, timeout_s: float) -> None:
        """Until a link has data or ``timeout_s`` passes (a serial link without a file descriptor: sleep)."""
        fds = [fd for link in self.links.values() if (fd := getattr(link, "fd", None)) is not None]
        if fds and len(fds) == len(self.links):
            select.select(fds, [], [], timeout_s)
        else:
            self.stop_event.wait(timeout_s)

    def _receive(self, now_s: float) -> None:
        for connection, link in self.links.items():
            connects = getattr(link, "connects", None)  # a TCP link that reconnected: its autopilot asked again
            if connects != self._connects.setdefault(connection, connects):
                self._connects[connection] = connects
                self._requested -= set(self._by_sysid[connection].values())
            for _ in range(_MAX_READ):
                if (message := link.recv_msg()) is None:
                    break
                kind = message.get_type()
                if kind == "BAD_DATA":
                    self.counters["bad_data"] += 1
                    continue
                vehicle_id = self._by_sysid[connection].get(message.get_srcSystem())
                if vehicle_id is None or message.get_srcComponent() != _AUTOPILOT_COMPONENT:
                    self.counters["other_systems"] += 1
                    continue
                self.bridge.ingest(vehicle_id, message, now_s)
                rate = self.options.request_rate_hz
                if rate is not None and vehicle_id not in self._requested:
                    self._request_rates(link, vehicle_id, rate)

    def _request_rates(self, link: mavfile, vehicle_id: str, rate: float) -> None:
        """SET_MESSAGE_INTERVAL for each telemetry message at ``rate`` Hz, and REQUEST_DATA_STREAM for its ArduPilot
        group."""
        sysid = self.sysids[vehicle_id]
        for message_id, stream in TELEMETRY.items():
            link.mav.command_long_send(sysid, _AUTOPILOT_COMPONENT, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                       message_id, 1e6 / rate, 0, 0, 0, 0, 0)
            link.mav.request_data_stream_send(sysid, _AUTOPILOT_COMPONENT, stream, max(1, round(rate)), 1)
        self._requested.add(vehicle_id)
        self.counters["rate_requests"] += 1
        log.info("%s: asked for its telemetry at %g Hz", vehicle_id, rate)

    def _apply(self, action: Publication | Liveliness) -> None:
        if isinstance(action, Liveliness):
            key = alive_key(action.vehicle_id, self.options.prefix)
            if action.alive:
                if self.session is not None:  # (open since _open(): the bridge runs after it)
                    self.tokens[action.vehicle_id] = self.session.liveliness().declare_token(key)
            else:
                token = self.tokens.pop(action.vehicle_id, None)
                if token is not None:
                    token.undeclare()
                self._requested.discard(action.vehicle_id)  # ask again when it comes back
            return
        announcement = self.announcer.due(action.ident, action.message.stamp_ns) if action.kind == "report" else None
        try:
            if announcement is not None:
                publish(self.publishers[(action.ident, "scenario")], announcement)
            publish(self.publishers[(action.ident, action.kind)], action.message)
        except ProtocolError as error:  # a value out of the wire's range must not stop the bridge
            self.counters[f"unpublishable_{action.kind}"] += 1
            log.error("%s %s not published: %s", action.ident, action.kind, error)


# ------------------------------------------------------------------ command line


def add_payload(sub: argparse._SubParsersAction) -> None:
    """Register ``sim-vehicles payload``."""
    parser = sub.add_parser(
        "payload", help="give an external autopilot's vehicle its reports against the scenario's simulated target",
        description="Reads each vehicle's autopilot telemetry (GLOBAL_POSITION_INT, ATTITUDE, GPS_RAW_INT) as a "
                    "passive MAVLink reader and publishes its NavReport, the simulated target sensor's "
                    "SensorReport against the scenario's target and city, the target's truth and the vehicle's "
                    "liveliness over Zenoh. Stop with Ctrl-C.")
    parser.add_argument("--vehicle", action="append", default=[], metavar="ID=CONNECTION",
                        help="a scenario vehicle and its autopilot's MAVLink connection (repeatable), e.g. "
                             "uav1=udpin:127.0.0.1:14551 (a MAVProxy --out) or uav1=tcp:127.0.0.1:5762")
    add_scenario_argument(parser)
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the target's and the sensors' random streams (default 0)")
    parser.add_argument("--duration", type=float, default=None, metavar="S",
                        help="wall seconds to run (default: until interrupted)")
    parser.add_argument("--stale-after", type=float, default=3.0, metavar="S",
                        help="withdraw a vehicle's liveliness (and publish nothing for it) when its last "
                             "GLOBAL_POSITION_INT is older than S seconds (default 3)")
    parser.add_argument("--request-rate", type=float, default=None, metavar="HZ",
                        help="ask each autopilot for GLOBAL_POSITION_INT, ATTITUDE and GPS_RAW_INT at HZ "
                             "(SET_MESSAGE_INTERVAL and REQUEST_DATA_STREAM) when first heard (default: ask "
                             "nothing, send nothing)")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    set_command(parser, _cmd_payload, check_payload)


def _vehicles(texts: list[str], known: list[str]) -> dict[str, str]:
    """``--vehicle ID=CONNECTION`` values, checked: each vehicle of the scenario, once, with a connection
    pymavlink can open."""
    if not texts:
        raise UsageError("give at least one --vehicle ID=CONNECTION, e.g. --vehicle uav1=udpin:127.0.0.1:14551")
    connections: dict[str, str] = {}
    for text in texts:
        vehicle_id, sep, connection = text.partition("=")
        if not sep or not vehicle_id.strip() or not connection.strip():
            raise UsageError(f"--vehicle {text!r}: expected ID=CONNECTION, e.g. uav1=udpin:127.0.0.1:14551")
        if vehicle_id not in known:
            raise UsageError(f"--vehicle {vehicle_id}: not in the scenario, whose vehicles are {', '.join(known)}")
        if vehicle_id in connections:
            raise UsageError(f"--vehicle {vehicle_id}: given twice; give each vehicle once")
        try:
            connections[vehicle_id] = check_connection(connection)
        except ValueError as error:
            raise UsageError(f"--vehicle {vehicle_id}: {error}") from None
    return connections


def check_payload(args: argparse.Namespace) -> PayloadRunner:
    """``sim-vehicles payload``'s input, checked: the runner it describes (nothing opened)."""
    scenario = load_scenario(args.scenario)
    positive(args.duration, "--duration")
    positive(args.stale_after, "--stale-after")
    positive(args.request_rate, "--request-rate")
    if args.request_rate is not None and args.request_rate > 50.0:
        raise UsageError(f"--request-rate {args.request_rate:g}: at most 50 Hz (what autopilots stream)")
    connections = _vehicles(args.vehicle, [v.id for v in scenario.vehicles])
    try:
        validate_prefix(args.prefix)
    except ProtocolError as error:
        raise UsageError(f"--prefix: {error}") from None
    try:
        zenoh = required_settings(args, "sim-vehicles payload")
    except ValueError as error:
        raise UsageError(error) from None
    base_dir = scenario_base_dir(args.scenario)
    bridge = PayloadBridge(scenario, build_world(scenario, base_dir), list(connections), args.seed,
                           args.stale_after, base_dir)
    return PayloadRunner(bridge, PayloadOptions(connections, zenoh, args.prefix, args.duration, args.request_rate))


def _cmd_payload(args: argparse.Namespace) -> int:
    runner = check_payload(args)
    stop_on_signals(runner.stop)
    log.info("%s: bridging %s", runner.bridge.scenario.name, ", ".join(runner.options.connections))
    try:
        runner.run()
    except (RuntimeError, OSError, ValueError) as error:  # a zenoh client with no router, a port in use
        print(f"sim-vehicles payload: error: {one_line(error)}", file=sys.stderr)
        return 1
    for line in runner.summary_lines():
        print(line)
    return 0
