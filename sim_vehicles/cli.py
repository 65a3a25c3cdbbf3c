"""The ``sim-vehicles`` command line.

Only subcommands that exist are registered, so ``sim-vehicles --help`` lists
exactly what works.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence

from gcs.cli_errors import OneLineParser, run_command
from gcs.config import ScenarioError
from sim_vehicles import __version__
from sim_vehicles.payload_command import add_payload
from sim_vehicles.run_command import add_run

SUBCOMMANDS: tuple[Callable[[argparse._SubParsersAction], None], ...] = (add_run, add_payload)
"""Registration functions, one per subcommand, in the order ``--help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every implemented subcommand."""
    parser = OneLineParser(
        prog="sim-vehicles",
        description="Simulated fixed-wing UAVs and the ground target they watch, on MAVLink and Zenoh.",
        epilog=None if SUBCOMMANDS else "No subcommands are implemented yet.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    if SUBCOMMANDS:
        sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
        for register in SUBCOMMANDS:
            register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sim-vehicles`` console script; returns the exit code (2 for bad input, with one line
    on stderr naming it: :mod:`gcs.cli_errors`)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if getattr(args, "handler", None) is None:
        parser.print_help()
        return 2
    return run_command(args, known=(ScenarioError,))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
