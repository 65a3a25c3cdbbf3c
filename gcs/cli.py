"""The ``gcs`` command line: the composition root for users.

This module parses arguments, sets up logging and loads the frozen scenario;
the work itself lives in ``gcs.app`` (the daemon) and ``gcs.bench``. Only
subcommands that exist are registered, so ``gcs --help`` lists exactly what
works.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Callable, Sequence

import msgspec

from gcs import __version__
from gcs.cli_errors import OneLineParser, run_command, set_command
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
    set_command(parser, _cmd_scenario)


SUBCOMMANDS: tuple[tuple[str, str], ...] = (
    ("demo", "gcs.daemon.demo:add_demo"),
    ("run", "gcs.daemon.cli:add_run"),
    ("status", "gcs.daemon.status_cli:add_status"),
    ("record", "gcs.recordings.record:add_record"),
    ("replay", "gcs.recordings.replay_cli:add_replay"),
    ("router", "gcs.adapters.zenoh_router:add_router"),
    ("scenario", "gcs.cli:_add_scenario"),
    ("bench", "gcs.bench.cli:add_bench"),
)
"""Each subcommand and its registration function (``module:function``), in the order ``--help`` lists them.
Registration modules are imported only when needed: ``gcs status`` (Docker's healthcheck) need not load SciPy."""


def _register(sub: argparse._SubParsersAction, target: str) -> None:
    module, _, function = target.partition(":")
    getattr(importlib.import_module(module), function)(sub)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every implemented subcommand, or with ``command``'s alone."""
    parser = OneLineParser(
        prog="gcs",
        description="Ground station that steers fixed-wing UAVs to keep a ground target in sight.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("--log-level", default="INFO",
                        choices=["DEBUG", "INFO", "WARNING", "ERROR"], help="logging threshold (default INFO)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, target in SUBCOMMANDS:
        if command is None or name == command:
            _register(sub, target)
    return parser


def requested_command(argv: Sequence[str]) -> str | None:
    """The subcommand ``argv`` names, if it names a known one before any help flag (else None: all are needed)."""
    names = {name for name, _ in SUBCOMMANDS}
    tokens = iter(argv)
    for token in tokens:
        if token == "--log-level":
            next(tokens, None)
        elif not token.startswith("-"):
            return token if token in names else None
        elif not token.startswith("--log-level="):
            return None  # --help, --version or a mistake: the full parser answers
    return None


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gcs`` console script; returns the process exit code (2 for bad input, with one
    line on stderr naming it: :mod:`gcs.cli_errors`)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(requested_command(argv))
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    return run_command(args, known=(ScenarioError,))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
