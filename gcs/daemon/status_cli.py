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
from gcs.daemon.status_text import counters_help, format_status
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import status_key
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
        print("\n".join(format_status(status, _decision_period_s(status.scenario))))
    return 0

