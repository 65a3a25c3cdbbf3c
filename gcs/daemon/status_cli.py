"""``gcs status``: ask a running daemon how it is (vehicles, links, tracks, counters).

Kept apart from ``gcs run`` so that the command imports only Zenoh and the
message definitions: it is the Docker healthcheck, run every few seconds.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

import msgspec

from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, open_session, query, required_settings
from gcs.cli_errors import UsageError, one_line, positive, set_command
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import status_key
from protocols.messages import DaemonStatus

__all__ = ["add_status", "query_status", "format_status", "check_status"]

log = logging.getLogger(__name__)


def add_status(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs status``."""
    parser = sub.add_parser("status", help="print a running daemon's status (vehicles, links, tracks, counters)",
                            description="Query gcs/daemon/status over Zenoh and print it.")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    parser.add_argument("--timeout", type=float, default=3.0, help="seconds to wait for the daemon (default 3)")
    parser.add_argument("--json", action="store_true", help="print the status as JSON")
    set_command(parser, _cmd_status, check_status)


def query_status(settings, prefix: str, timeout_s: float) -> DaemonStatus | None:
    """The daemon's status, or None when no daemon answered within ``timeout_s``."""
    with open_session(settings) as session:
        for sample in query(session, status_key(prefix), timeout_s):
            return decode(sample.payload.to_bytes(), str(sample.encoding), DaemonStatus)
    return None


def format_status(status: DaemonStatus) -> list[str]:
    """Human-readable lines: the daemon, one line per vehicle, one per track (or ``no tracks``), the counters."""
    lines = [f"scenario {status.scenario}, up {status.uptime_s:.0f} s, last track stamp "
             f"{status.last_track_stamp_ns if status.last_track_stamp_ns is not None else 'none'}"]
    if status.command_age_ms_median is not None:
        lines.append(f"command age median {status.command_age_ms_median:.0f} ms, p99 "
                     f"{status.command_age_ms_p99:.0f} ms (vehicle time flown less the decision step's stamp)")
    for vehicle in status.vehicles:
        lines.append(f"  {vehicle.vehicle_id:<10} sysid {vehicle.sysid or '-':>3}  link {vehicle.link:<7} "
                     f"(heartbeat {vehicle.heartbeat or '-'}, liveliness {vehicle.liveliness or '-'})  "
                     f"reports {vehicle.reports:>6}  autopilot {vehicle.autopilot or '-'}  "
                     f"control {vehicle.control or '-'}")
    for track in status.tracks:
        speed = "-" if track.speed_mps is None else f"{track.speed_mps:.1f} m/s"
        lines.append(f"  track {track.target_id:<10} at ({track.x_m:.1f}, {track.y_m:.1f}) m  "
                     f"1-sigma {track.position_std_m:.1f} m  speed {speed}  stamp {track.stamp_ns}  "
                     f"vehicles {', '.join(track.contributing_vehicles) or '-'}")
    if not status.tracks:
        lines.append("  no tracks")
    for name, value in sorted(status.counters.items()):
        lines.append(f"  {name:<40} {value:>10}")
    return lines


def check_status(args: argparse.Namespace):
    """``gcs status``'s input, checked: the zenoh settings to ask with."""
    positive(args.timeout, "--timeout")
    try:
        status_key(args.prefix)
    except ProtocolError as error:
        raise UsageError(f"--prefix: {error}") from None
    try:
        return required_settings(args, "gcs status")
    except ValueError as error:
        raise UsageError(error) from None


def _cmd_status(args: argparse.Namespace) -> int:
    settings = check_status(args)
    try:
        status = query_status(settings, args.prefix, args.timeout)
    except (RuntimeError, ProtocolError) as error:
        print(f"gcs status: error: {one_line(error)}", file=sys.stderr)
        return 1
    if status is None:
        print(f"gcs status: error: no daemon answered on {status_key(args.prefix)} within {args.timeout:g} s "
              f"(connect: {', '.join(settings.connect) or 'none'}); is gcs run up there?", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(msgspec.to_builtins(status), indent=2))
    else:
        print("\n".join(format_status(status)))
    return 0

