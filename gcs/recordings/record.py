"""``gcs record``: everything on Zenoh under a prefix, to an MCAP file (:mod:`gcs.adapters.recording`).

The recorder is a Zenoh peer that connects to ``tcp/127.0.0.1:7447`` by
default, where ``gcs run`` listens. Without a daemon (or router) there, nobody
is there to record: to record the simulated vehicles alone, let the recorder be
where they connect, ``gcs record -o FILE --zenoh-listen tcp/127.0.0.1:7447``
(with ``--zenoh-listen`` and no ``--zenoh-connect`` it connects nowhere). When
no peer or router has been reached after :data:`NO_PEER_WARN_S`, it warns,
naming the endpoints and that fix. A recording that ends with no message is a
warning and exit status 1 unless ``--allow-empty``. SIGINT/SIGTERM (or
``--duration``) finish the file.
"""

from __future__ import annotations

import argparse
import logging
import queue
import sys
import threading
import time
from pathlib import Path

import zenoh

from gcs.adapters.recording import Recorder
from gcs.adapters.zenoh_session import (DEFAULT_ENDPOINT, ZenohSettings, add_zenoh_arguments, listening_endpoints,
                                        open_session, required_settings)
from gcs.cli_errors import UsageError, one_line, positive, set_command, stop_on_signals, writable_file
from protocols.errors import ProtocolError
from protocols.keys import validate_prefix

__all__ = ["add_record", "check_record", "record", "NO_PEER_WARN_S"]

log = logging.getLogger(__name__)

NO_PEER_WARN_S = 3.0
"""Wall seconds without any zenoh peer or router before the recorder says nobody is there."""


def add_record(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs record``."""
    parser = sub.add_parser(
        "record", help="record the Zenoh traffic under a prefix to MCAP",
        description="Subscribe to everything under the prefix (reports, nav, tracks, plans, truth, liveliness) and "
                    "write the exact payloads to an MCAP file; Ctrl-C or SIGTERM finishes the file. It connects "
                    f"to {DEFAULT_ENDPOINT} (where gcs run listens); to record simulated vehicles without a "
                    f"daemon, give --zenoh-listen {DEFAULT_ENDPOINT} (where they connect).")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.mcap")
    parser.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S wall seconds")
    parser.add_argument("--allow-empty", action="store_true",
                        help="exit 0 even when nothing was recorded (default: a warning and exit status 1)")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    set_command(parser, _cmd_record, check_record)


def check_record(args: argparse.Namespace) -> ZenohSettings:
    """``gcs record``'s input, checked: the zenoh settings (listening only, when only ``--zenoh-listen`` is
    given)."""
    writable_file(args.output, "--output")
    positive(args.duration, "--duration")
    try:
        validate_prefix(args.prefix)
    except ProtocolError as error:
        raise UsageError(f"--prefix: {error}") from None
    if args.zenoh_listen and args.zenoh_connect is None:
        args.zenoh_connect = []  # the meeting point itself: connecting to its own endpoint would make no sense
    try:
        return required_settings(args, "gcs record")
    except ValueError as error:
        raise UsageError(error) from None


def _no_peer_warning(settings: ZenohSettings, listening: list[str]) -> str:
    where = (f"connecting to {', '.join(settings.connect)}" if settings.connect else "") + (
        (" and " if settings.connect else "") + f"listening on {', '.join(listening)}" if listening else "")
    return (f"no zenoh peer or router reached after {NO_PEER_WARN_S:g} s ({where}): nothing to record. Start gcs run "
            f"(or gcs router) there, or record the simulated vehicles without a daemon with --zenoh-listen "
            f"{DEFAULT_ENDPOINT}, where sim-vehicles run connects")


def record(settings: ZenohSettings, prefix: str, output: Path, stop: threading.Event,
           duration_s: float | None = None, announce=print) -> int:
    """Record until ``stop`` (or ``duration_s`` of wall time); returns the number of messages written.

    ``announce`` gets one line once the session is open: what is recorded where, and the endpoints it
    listens on (a port of 0 read back). RuntimeError when the session cannot open.
    """
    inbox: queue.Queue = queue.Queue()
    started = time.monotonic()
    deadline = None if duration_s is None else started + duration_s
    recorder = Recorder(output)
    try:
        with open_session(settings) as session:
            session.declare_subscriber(f"{prefix}/**", lambda s: inbox.put(
                (str(s.key_expr), s.payload.to_bytes(), str(s.encoding), time.time_ns())))
            session.liveliness().declare_subscriber(f"{prefix}/**", lambda s: inbox.put(
                (str(s.key_expr), s.kind == zenoh.SampleKind.PUT, None, time.time_ns())), history=True)
            listening = listening_endpoints(session) if any(e.endswith(":0") for e in settings.listen) \
                else list(settings.listen)
            announce(f"recording {prefix}/** to {output}"
                     + (f"; listening on {', '.join(listening)}" if listening else "")
                     + (f"; connecting to {', '.join(settings.connect)}" if settings.connect else ""))
            warned = False
            while not stop.is_set() and (deadline is None or time.monotonic() < deadline):
                _drain(inbox, recorder, timeout=0.1)
                if not warned and time.monotonic() - started >= NO_PEER_WARN_S:
                    warned = True
                    if not list(session.info.peers_zid()) and not list(session.info.routers_zid()):
                        log.warning("%s", _no_peer_warning(settings, listening))
            _drain(inbox, recorder, timeout=0.0)
    finally:
        recorder.finish()
    return recorder.messages


def _drain(inbox: queue.Queue, recorder: Recorder, timeout: float) -> None:
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
        try:
            item = inbox.get_nowait()
        except queue.Empty:
            return


def _cmd_record(args: argparse.Namespace) -> int:
    settings = check_record(args)
    stop = threading.Event()
    stop_on_signals(stop.set)
    try:
        messages = record(settings, args.prefix, args.output, stop, args.duration,
                          announce=lambda line: print(line, flush=True))
    except (RuntimeError, OSError) as error:
        print(f"gcs record: error: {one_line(error)}", file=sys.stderr)
        return 1
    print(f"recorded {messages} messages to {args.output}")
    if messages == 0 and not args.allow_empty:
        log.warning("the recording %s is empty: nobody published under %s/ (is anything connected to the same "
                    "endpoint? see the warning above); --allow-empty accepts an empty recording", args.output,
                    args.prefix)
        return 1
    return 0
