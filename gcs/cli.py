"""The ``gcs`` command line: the composition root for users.

This module parses arguments, sets up logging and loads the frozen scenario;
the work itself lives in the shells (``gcs.daemon``, ``gcs.recordings``). Only
subcommands that exist are registered, so ``gcs --help`` lists exactly what
works. The benchmarks are a command of their own, ``gcs-bench`` (``benchmarks/``).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence

import msgspec

from gcs import __version__
from gcs.adapters.osm.command import add_from_osm
from gcs.cli_commands import CommandLine, Subcommand
from gcs.cli_errors import set_command
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
        help="list, show, check or build scenario files (from OpenStreetMap)",
        description="List the shipped scenarios, show one fully resolved, check a TOML file, or build one from "
                    "an OpenStreetMap extract.",
    )
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    actions.add_parser("list", help="names and descriptions of the shipped scenarios")
    for action, text in (("show", "print a scenario with every default filled in, as JSON"),
                         ("check", "validate a scenario; exit 2 naming the bad key")):
        p = actions.add_parser(action, help=text)
        p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                       help=f"shipped name or path to a .toml file (default: {DEFAULT_SCENARIO})")
    set_command(parser, _cmd_scenario)
    add_from_osm(actions)


SUBCOMMANDS: tuple[Subcommand, ...] = (
    Subcommand("demo", "gcs.daemon.demo:add_demo", "daemon + simulated vehicles on loopback, live progress and a summary"),
    Subcommand("run", "gcs.daemon.cli:add_run",
               "the ground-station daemon: reports in over Zenoh, headings out over MAVLink"),
    Subcommand("status", "gcs.daemon.status_cli:add_status",
               "print a running daemon's status (vehicles, links, tracks, counters)"),
    Subcommand("record", "gcs.recordings.record:add_record", "record the Zenoh traffic under a prefix to MCAP"),
    Subcommand("replay", "gcs.recordings.replay_cli:add_replay", "summarise, republish or process a recording"),
    Subcommand("router", "gcs.daemon.router:add_router", "a Zenoh router for clients (no zenohd needed)"),
    Subcommand("scenario", "gcs.cli:_add_scenario", "list, show, check or build scenario files (from OpenStreetMap)"),
)
"""Each subcommand, in the order ``--help`` lists them; only the one named is imported (:mod:`gcs.cli_commands`):
``gcs --help`` loads none, ``gcs status`` (Docker's healthcheck) need not load SciPy."""


COMMAND_LINE = CommandLine("gcs", "Ground station that steers fixed-wing UAVs to keep a ground target in sight.",
                           __version__, SUBCOMMANDS)
build_parser = COMMAND_LINE.build_parser
requested_command = COMMAND_LINE.requested_command


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gcs`` console script; returns the process exit code (2 for bad input, with one
    line on stderr naming it; 130 on Ctrl-C: :mod:`gcs.cli_errors`)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if _first_word(argv) == "bench":
        rest = argv[argv.index("bench") + 1:]
        print(f"gcs: error: the benchmarks are a command of their own: gcs-bench {' '.join(rest) or '--help'}",
              file=sys.stderr)
        return 2
    return COMMAND_LINE.main(argv, known=(ScenarioError,))


def _first_word(argv: Sequence[str]) -> str | None:
    """The first argument that is neither an option nor ``--log-level``'s value."""
    tokens = iter(argv)
    for token in tokens:
        if token == "--log-level":
            next(tokens, None)
        elif not token.startswith("-"):
            return token
    return None


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
