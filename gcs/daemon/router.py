"""``gcs router``: a Zenoh router in a Python session, for clients where there is no ``zenohd``.

``zenohd`` is on neither PyPI nor Debian; a session opened in ``router`` mode
routes between its clients and peers, keeps their liveliness tokens and adds
timestamps (docs/protocol.md#zenoh). It takes the same ``--zenoh-config`` file as
every other command, so user/password authentication (a ``dictionary_file``)
and TLS are configured the same way. Stop with Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
from dataclasses import replace

from gcs.adapters.zenoh_session import (DEFAULT_ENDPOINT, add_zenoh_arguments, listening_endpoints, open_session,
                                        required_settings)
from gcs.cli_errors import UsageError, one_line, set_command, stop_on_signals

__all__ = ["add_router", "check_router"]

log = logging.getLogger(__name__)


def add_router(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs router``."""
    parser = sub.add_parser("router", help="a Zenoh router for clients (no zenohd needed)",
                            description="Open a Zenoh session in router mode and route until Ctrl-C or SIGTERM. "
                                        "--zenoh-mode is ignored (always router). A listening port of 0 lets the "
                                        "system choose one; the first line printed says which.")
    add_zenoh_arguments(parser, listen=(DEFAULT_ENDPOINT,), connect=())
    set_command(parser, _cmd_router, check_router)


def check_router(args: argparse.Namespace):
    """``gcs router``'s input, checked: its zenoh settings (router mode)."""
    try:
        return replace(required_settings(args, "a router"), mode="router")
    except ValueError as error:
        raise UsageError(error) from None


def _cmd_router(args: argparse.Namespace) -> int:
    settings = check_router(args)
    stop = threading.Event()
    stop_on_signals(stop.set)
    try:
        with open_session(settings) as session:
            listening = listening_endpoints(session) if any(e.endswith(":0") for e in settings.listen) \
                else list(settings.listen)
            print(f"router listening on {', '.join(listening) or 'nothing'}"
                  + (f", connected to {', '.join(settings.connect)}" if settings.connect else ""), flush=True)
            while not stop.wait(0.2):
                pass
    except RuntimeError as error:  # e.g. the port is taken
        print(f"gcs router: error: {one_line(error)}", file=sys.stderr)
        return 1
    return 0
