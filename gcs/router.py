"""``gcs router``: a Zenoh router in a Python session, for clients where there is no ``zenohd``.

``zenohd`` is on neither PyPI nor Debian; a session opened in ``router`` mode
routes between its clients and peers, keeps their liveliness tokens and adds
timestamps (reference/zenoh.md). It takes the same ``--zenoh-config`` file as
every other command, so user/password authentication (a ``dictionary_file``)
and TLS are configured the same way. Stop with Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import logging
import signal
import threading
from dataclasses import replace

from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, open_session, required_settings

__all__ = ["add_router"]

log = logging.getLogger(__name__)


def add_router(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs router``."""
    parser = sub.add_parser("router", help="a Zenoh router for clients (no zenohd needed)",
                            description="Open a Zenoh session in router mode and route until Ctrl-C or SIGTERM. "
                                        "--zenoh-mode is ignored (always router).")
    add_zenoh_arguments(parser, listen=(DEFAULT_ENDPOINT,), connect=())
    parser.set_defaults(handler=_cmd_router)


def _cmd_router(args: argparse.Namespace) -> int:
    try:
        settings = replace(required_settings(args, "a router"), mode="router")
    except ValueError as error:
        log.error("%s", error)
        return 2
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    try:
        with open_session(settings):
            print(f"router listening on {', '.join(settings.listen) or 'nothing'}"
                  + (f", connected to {', '.join(settings.connect)}" if settings.connect else ""), flush=True)
            while not stop.wait(0.2):
                pass
    except RuntimeError as error:  # e.g. the port is taken
        log.error("%s", error)
        return 1
    return 0
