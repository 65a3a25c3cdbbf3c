"""``gcs status``: ask a running daemon how it is (vehicles, links, tracks, counters); with ``--federation
PREFIX``, the federation of daemons under that prefix instead (:mod:`gcs.daemon.federation_status`).

Kept apart from ``gcs run`` so that the command imports only Zenoh and the
message definitions: it is the Docker healthcheck, run every few seconds.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time

import msgspec

from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, open_session, query, required_settings
from gcs.cli_errors import UsageError, one_line, positive, set_command
from gcs.daemon.federation_status import format_federation, query_federation
from gcs.daemon.status_text import counters_help, format_status
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import member_tracks_selector, status_key
from protocols.messages import DaemonStatus

__all__ = ["add_status", "query_status", "format_status", "check_status"]

log = logging.getLogger(__name__)


def add_status(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs status``."""
    parser = sub.add_parser("status", help="print a running daemon's status (vehicles, links, tracks, counters)",
                            description="Query gcs/daemon/status over Zenoh and print it: the daemon, each vehicle "
                                        "(link, reports, who flies it), each track, the steering commands' age and "
                                        "the counters. Times are UTC with their age at the status; docs/cli.md has "
                                        "the same table of counters.",
                            epilog=counters_help(), formatter_class=argparse.RawDescriptionHelpFormatter)
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    parser.add_argument("--timeout", type=float, default=3.0, help="seconds to wait for the daemon (default 3)")
    parser.add_argument("--json", action="store_true", help="print the status as JSON")
    parser.add_argument("--federation", metavar="PREFIX", default=None,
                        help="print the federation of daemons under this prefix instead (gcs run --federation): "
                             "each member's area, vehicles, spare vehicles and tracks, and each global track with "
                             "the members holding it, from the members' answers on PREFIX/federation/*/tracks")
    set_command(parser, _cmd_status, check_status)


def query_status(settings, prefix: str, timeout_s: float) -> DaemonStatus | None:
    """The daemon's status, or None when no daemon answered within ``timeout_s``."""
    with open_session(settings) as session:
        for sample in query(session, status_key(prefix), timeout_s):
            return decode(sample.payload.to_bytes(), str(sample.encoding), DaemonStatus)
    return None


def _decision_period_s(scenario: str) -> float | None:
    """The decision period of a shipped scenario the status names (None for one this machine does not have)."""
    from gcs.config import ScenarioError
    from gcs.scenarios import load_scenario

    try:
        return load_scenario(scenario).time.step_s
    except (ScenarioError, OSError, ValueError):
        return None


def check_status(args: argparse.Namespace):
    """``gcs status``'s input, checked: the zenoh settings to ask with."""
    positive(args.timeout, "--timeout")
    for option, prefix in (("--prefix", args.prefix), ("--federation", getattr(args, "federation", None))):
        try:
            if prefix is not None:
                status_key(prefix)
        except ProtocolError as error:
            raise UsageError(f"{option}: {error}") from None
    try:
        return required_settings(args, "gcs status")
    except ValueError as error:
        raise UsageError(error) from None


def _cmd_federation(args: argparse.Namespace, settings) -> int:
    try:
        members = query_federation(settings, args.federation, args.timeout)
    except RuntimeError as error:
        print(f"gcs status: error: {one_line(error)}", file=sys.stderr)
        return 1
    if not members:
        print(f"gcs status: error: no member answered on {member_tracks_selector(args.federation)} within "
              f"{args.timeout:g} s (connect: {', '.join(settings.connect) or 'none'}); is gcs run --federation "
              f"{args.federation} up there?", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(msgspec.to_builtins(members), indent=2))
    else:
        print("\n".join(format_federation(args.federation, members, time.time_ns())))
    return 0


def _cmd_status(args: argparse.Namespace) -> int:
    settings = check_status(args)
    if args.federation is not None:
        return _cmd_federation(args, settings)
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
        print("\n".join(format_status(status, _decision_period_s(status.scenario))))
    return 0

