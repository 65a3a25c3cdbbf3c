"""The ``gcs`` command line: the composition root for users.

This module parses arguments, sets up logging and loads the frozen scenario;
the work itself lives in ``gcs.app`` (the daemon) and ``gcs.bench``. Only
subcommands that exist are registered, so ``gcs --help`` lists exactly what
works.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence

import msgspec

from gcs import __version__
from gcs.bench.cli import add_bench
from gcs.daemon.cli import add_run, add_status
from gcs.demo import add_demo
from gcs.replay import add_record, add_replay
from gcs.router import add_router
from gcs.config import ScenarioError
from gcs.scenarios import DEFAULT_SCENARIO, list_scenarios, load_scenario

log = logging.getLogger(__name__)

Handler = Callable[[argparse.Namespace], int]


def _cmd_scenario(args: argparse.Namespace) -> int:
    if args.action == "list":
        for name in list_scenarios():
            print(f"{name}: {load_scenario(name).description}")
        return 0
    scenario = load_scenario(args.scenario)
    if args.action == "check":
        print(f"{args.scenario}: ok ({len(scenario.vehicles)} vehicles, {scenario.time.duration_s:g} s)")
    else:
        print(msgspec.json.format(msgspec.json.encode(scenario), indent=2).decode())
    return 0


def _add_scenario(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "scenario",
        help="list, show or check scenario files",
        description="List the shipped scenarios, show one fully resolved, or check a TOML file.",
    )
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    actions.add_parser("list", help="names and descriptions of the shipped scenarios")
    for action, text in (("show", "print a scenario with every default filled in, as JSON"),
                         ("check", "validate a scenario; exit 2 naming the bad key")):
        p = actions.add_parser(action, help=text)
        p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                       help=f"shipped name or path to a .toml file (default: {DEFAULT_SCENARIO})")
    parser.set_defaults(handler=_cmd_scenario)


SUBCOMMANDS: tuple[Callable[[argparse._SubParsersAction], None], ...] = (add_demo, add_run, add_status, add_record, add_replay,
                                                                      add_router, _add_scenario, add_bench)
"""Registration functions, one per subcommand, in the order ``--help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every implemented subcommand."""
    parser = argparse.ArgumentParser(
        prog="gcs",
        description="Ground station that steers fixed-wing UAVs to keep a ground target in sight.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("--log-level", default="INFO",
                        choices=["DEBUG", "INFO", "WARNING", "ERROR"], help="logging threshold (default INFO)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for register in SUBCOMMANDS:
        register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gcs`` console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        return args.handler(args)
    except ScenarioError as exc:
        print(f"gcs: scenario error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
