"""``gcs record``: everything on Zenoh under a prefix, to an MCAP file (:mod:`gcs.adapters.recording`).

Where the recorder is decides what it hears. A Zenoh peer does not forward one
peer's messages to another, but it does forward everything to its clients, as a
router does to everyone. So the recorder joins as a **client**, of the daemon
(``gcs run``, a peer) or of a router (``gcs router``, ``zenohd``), which then hands it
the vehicles' messages with the rest; and where it must be the meeting point
itself (``--zenoh-listen``), it listens as a **router**, so that the vehicles, and
a daemon that joins it, hear each other through it too.

With no endpoint given it goes where the traffic is: it joins
``tcp/127.0.0.1:7447`` when somebody listens there (a daemon or a router), and
listens there itself when nobody does, where ``sim-vehicles run`` connects by
default (a daemon started afterwards joins it with ``--zenoh-mode client``).
``--zenoh-connect`` joins the endpoints given (nobody there: an error, exit
status 1), ``--zenoh-listen`` listens there, ``--zenoh-mode peer`` makes it a
peer all the same.

It says when it first hears each vehicle and when a vehicle leaves (its liveliness
token withdrawn: after everything it published), and the scenario the vehicles announce
(:class:`~protocols.messages.VehicleScenario`), which it keeps in the file
(:meth:`~gcs.adapters.recording.Recorder.write_scenario`); when no vehicle has
been heard after :data:`QUIET_NOTICE_S` it says where it waits for them. A
recording that ends without any vehicle report is a warning and exit status 1
unless ``--allow-empty``. SIGINT/SIGTERM (or ``--duration``) finish the file.

``--federation PREFIX`` also records a federation of daemons' messages and members'
liveliness (``PREFIX/federation/**``), which ``gcs replay --process --federation`` feeds
back to a member's engine.
"""

from __future__ import annotations

import argparse
import logging
import queue
import sys
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import zenoh

from gcs.adapters.recording import Recorder
from gcs.adapters.zenoh_session import (DEFAULT_ENDPOINT, ZenohSettings, add_zenoh_arguments, clean_error,
                                        listening_endpoints, open_session, required_settings)
from gcs.cli_errors import UsageError, one_line, positive, set_command, stop_on_signals, writable_file
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import parse_key, validate_prefix
from protocols.messages import VehicleScenario

__all__ = ["add_record", "check_record", "record", "RecordSettings", "Recording", "QUIET_NOTICE_S"]

log = logging.getLogger(__name__)

QUIET_NOTICE_S = 3.0
"""Wall seconds without any vehicle message before the recorder says where it waits for them."""
MAX_CACHED_KEYS = 4096
"""Keys whose kind the recorder remembers (a few per vehicle)."""


def add_record(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs record``."""
    parser = sub.add_parser(
        "record", help="record the Zenoh traffic under a prefix to MCAP",
        description="Subscribe to everything under the prefix (the vehicles' reports, nav, scenario and liveliness, "
                    "the simulator's truth, the daemon's tracks, plans and status) and write the exact payloads to an "
                    "MCAP file; Ctrl-C or SIGTERM finishes the file. With no endpoint given it joins the daemon or "
                    f"router listening on {DEFAULT_ENDPOINT} as a client, or, when nobody listens there, listens "
                    "there itself (as a router), where sim-vehicles run connects. --zenoh-connect joins those "
                    "endpoints as a client (nobody there: exit status 1); --zenoh-listen listens there as a router. A "
                    "recording without any vehicle report is a warning and exit status 1 (--allow-empty: 0).")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.mcap")
    parser.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S wall seconds")
    parser.add_argument("--allow-empty", action="store_true",
                        help="exit 0 even when no vehicle report was recorded (default: a warning and exit status 1)")
    parser.add_argument("--federation", metavar="PREFIX", default=None,
                        help="also record the federation of daemons under this prefix (its members' tracks and "
                             "liveliness, PREFIX/federation/**)")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,), mode="client",
                        mode_help="client, or router where it listens")
    set_command(parser, _cmd_record, check_record)


@dataclass(frozen=True)
class RecordSettings:
    """Where the recorder goes: its zenoh settings, and whether to find the traffic at the one endpoint it
    connects to (:data:`DEFAULT_ENDPOINT` when no endpoint is given): join whoever listens there as a client,
    else listen there as a router."""

    zenoh: ZenohSettings
    find: bool = False


def check_record(args: argparse.Namespace) -> RecordSettings:
    """``gcs record``'s input, checked: where it records (see the module docstring)."""
    writable_file(args.output, "--output")
    positive(args.duration, "--duration")
    for option, prefix in (("--prefix", args.prefix), ("--federation", args.federation)):
        try:
            if prefix is not None:
                validate_prefix(prefix)
        except ProtocolError as error:
            raise UsageError(f"{option}: {error}") from None
    if args.zenoh_listen:
        args.zenoh_default_mode = "router"  # the meeting point: whoever connects hears everyone through it
        if args.zenoh_connect is None:
            args.zenoh_connect = []  # connecting to its own endpoint would make no sense
    try:
        settings = required_settings(args, "gcs record")
    except ValueError as error:
        raise UsageError(error) from None
    find = (args.zenoh_listen is None and args.zenoh_connect is None and args.zenoh_mode is None
            and settings.mode == "client" and not settings.listen and tuple(settings.connect) == (DEFAULT_ENDPOINT,))
    return RecordSettings(settings, find)


def _open(where: RecordSettings) -> tuple[zenoh.Session, ZenohSettings]:
    """The session, and the settings it was opened with: with ``find``, a client of whoever listens on the
    endpoint, else a router listening there."""
    endpoints = ", ".join(where.zenoh.connect)
    try:
        return open_session(where.zenoh), where.zenoh
    except RuntimeError as error:
        joining = clean_error(error.__cause__ or error)
        if not where.find and where.zenoh.mode == "client":
            raise RuntimeError(
                f"nobody answers on {endpoints} ({joining}): start gcs run or gcs router there first; without "
                f"--zenoh-connect, gcs record listens on {DEFAULT_ENDPOINT} itself when nobody is there") from error
        if not where.find:
            raise
    meeting = replace(where.zenoh, mode="router", listen=tuple(where.zenoh.connect), connect=())
    try:
        return open_session(meeting), meeting
    except RuntimeError as error:
        raise RuntimeError(f"cannot join {endpoints} ({joining}) nor listen there "
                           f"({clean_error(error.__cause__ or error)})") from error


@dataclass
class Recording:
    """What a recording holds: messages, vehicle reports, the vehicles heard, the scenario they announced."""

    messages: int = 0
    reports: int = 0
    vehicles: list[str] = field(default_factory=list)
    scenario: VehicleScenario | None = None


class _Tally:
    """Looks at each recorded message: counts reports, says which vehicle is heard first and which scenario the
    vehicles announce (kept in the file), warns about a vehicle announcing another."""

    def __init__(self, prefix: str, recorder: Recorder, announce) -> None:
        self.prefix, self.recorder, self.announce = prefix, recorder, announce
        self.recording = Recording()
        self._kinds: dict[str, tuple[str | None, str | None]] = {}
        self._warned: set[tuple[str, str]] = set()

    def kind(self, key: str) -> tuple[str | None, str | None]:
        kind = self._kinds.get(key)
        if kind is None:
            try:
                parsed = parse_key(key, self.prefix)
                kind = (parsed.kind, parsed.ident)
            except ProtocolError:
                kind = (None, None)
            if len(self._kinds) < MAX_CACHED_KEYS:  # a flood of made-up keys cannot grow it beyond this
                self._kinds[key] = kind
        return kind

    def see(self, key: str, payload: bytes | bool, encoding: str | None) -> None:
        kind, ident = self.kind(key)
        if kind == "alive" and payload is False:
            self.announce(f"vehicle {ident} left")  # its liveliness token withdrawn, after all it published
        elif kind in ("report", "nav", "alive", "scenario") and ident is not None \
                and ident not in self.recording.vehicles:
            self.recording.vehicles.append(ident)
            self.announce(f"hearing vehicle {ident}")
        if kind == "report":
            self.recording.reports += 1
        if kind == "scenario" and encoding is not None and isinstance(payload, bytes):
            try:
                self._scenario(decode(payload, encoding, VehicleScenario))
            except ProtocolError:
                pass  # recorded as it came, like any message; not one to name the scenario by

    def _scenario(self, announced: VehicleScenario) -> None:
        first = self.recording.scenario
        if first is None:
            self.recording.scenario = announced
            self.recorder.write_scenario(announced.scenario, announced.fingerprint)
            self.announce(f"scenario {announced.scenario} (fingerprint {announced.fingerprint}), as vehicle "
                          f"{announced.vehicle_id} announced")
        elif (announced.scenario, announced.fingerprint) != (first.scenario, first.fingerprint) and \
                (announced.scenario, announced.fingerprint) not in self._warned:
            self._warned.add((announced.scenario, announced.fingerprint))
            log.warning("vehicle %s flies scenario %s (fingerprint %s), not %s (fingerprint %s) as %s: the recording "
                        "keeps the first", announced.vehicle_id, announced.scenario, announced.fingerprint,
                        first.scenario, first.fingerprint, first.vehicle_id)


def _where(settings: ZenohSettings, listening: list[str]) -> str:
    parts = ([f"listening on {', '.join(listening)}"] if listening else []) + (
        [f"{'joined' if settings.mode == 'client' else 'connecting to'} {', '.join(settings.connect)}"]
        if settings.connect else [])
    return "; ".join(parts)


def record(where: RecordSettings, prefix: str, output: Path, stop: threading.Event,
           duration_s: float | None = None, announce=print, federation: str | None = None) -> Recording:
    """Record until ``stop`` (or ``duration_s`` of wall time); what the recording holds (with ``federation``, the
    federation's keys under that prefix too).

    ``announce`` gets one line once the session is open (what is recorded where, with the endpoints it
    listens on, a port of 0 read back), and one as each vehicle is first heard, as one leaves, and as the
    scenario is first announced. RuntimeError when the session cannot open.
    """
    inbox: queue.Queue = queue.Queue()
    started = time.monotonic()
    deadline = None if duration_s is None else started + duration_s
    recorder = Recorder(output)
    tally = _Tally(prefix, recorder, announce)
    try:
        session, settings = _open(where)
        inside = federation is None or f"{federation}/".startswith(f"{prefix}/")  # already under prefix/**
        selectors = [f"{prefix}/**"] + ([] if inside else [f"{federation}/federation/**"])
        with session:
            for selector in selectors:
                session.declare_subscriber(selector, lambda s: inbox.put(
                    (str(s.key_expr), s.payload.to_bytes(), str(s.encoding), time.time_ns())))
                session.liveliness().declare_subscriber(selector, lambda s: inbox.put(
                    (str(s.key_expr), s.kind == zenoh.SampleKind.PUT, None, time.time_ns())), history=True)
            listening = listening_endpoints(session) if any(e.endswith(":0") for e in settings.listen) \
                else list(settings.listen)
            found = (" (nobody listened there: the vehicles connect here)" if where.find and listening
                     else " (the daemon or router there forwards everything)" if where.find else "")
            announce(f"recording {' and '.join(selectors)} to {output} as a zenoh {settings.mode}; "
                     f"{_where(settings, listening)}" + found)
            noticed = False
            while not stop.is_set() and (deadline is None or time.monotonic() < deadline):
                _drain(inbox, recorder, tally, timeout=0.1)
                if not noticed and not tally.recording.vehicles and time.monotonic() - started >= QUIET_NOTICE_S:
                    noticed = True
                    log.info("no vehicle heard yet (%s); recording what comes", _where(settings, listening))
            _drain(inbox, recorder, tally, timeout=0.0)
    finally:
        recorder.finish()
    tally.recording.messages = recorder.messages
    return tally.recording


def _drain(inbox: queue.Queue, recorder: Recorder, tally: _Tally, timeout: float) -> None:
    try:
        item = inbox.get(timeout=timeout) if timeout else inbox.get_nowait()
    except queue.Empty:
        return
    while True:
        key, payload, encoding, time_ns = item
        if encoding is None:
            recorder.write_liveliness(key, payload, time_ns)
        else:
            recorder.write(key, payload, encoding, time_ns)
        tally.see(key, payload, encoding)
        try:
            item = inbox.get_nowait()
        except queue.Empty:
            return


def _cmd_record(args: argparse.Namespace) -> int:
    where = check_record(args)
    stop = threading.Event()
    stop_on_signals(stop.set)
    try:
        held = record(where, args.prefix, args.output, stop, args.duration,
                      announce=lambda line: print(line, flush=True), federation=args.federation)
    except (RuntimeError, OSError) as error:
        print(f"gcs record: error: {one_line(error)}", file=sys.stderr)
        return 1
    print(f"recorded {held.messages} messages to {args.output}: {held.reports} vehicle reports from "
          f"{', '.join(held.vehicles) or 'no vehicle'}"
          + (f", scenario {held.scenario.scenario}" if held.scenario is not None else ""))
    if held.reports == 0:
        log.warning("the recording %s holds no vehicle report: no vehicle published under %s/vehicle/ while it ran "
                    "(sim-vehicles run connects to %s; start the vehicles while it records)%s", args.output,
                    args.prefix, DEFAULT_ENDPOINT, "" if args.allow_empty else "; --allow-empty accepts it")
        return 0 if args.allow_empty else 1
    return 0
