"""Subcommands registered on demand, so that a command line starts in a fraction of a second.

A command line (``gcs``, ``sim-vehicles``) lists its subcommands as :class:`Subcommand` rows:
a name, the ``module:function`` that registers its parser, and the one line ``--help`` shows.
:meth:`CommandLine.main` imports the registration module of the subcommand named on the command
line alone (:meth:`CommandLine.requested_command`); with none named (``--help``, ``--version``, a typo)
its parser lists every subcommand from the table without importing any of them
(:meth:`CommandLine.listing_parser`). The registration modules
import NumPy, SciPy, Zenoh and pymavlink (a second or more); ``gcs --help`` needs none of them.
The table's help lines are the registered parsers' own (a unit test holds them equal).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from gcs.cli_errors import OneLineParser, guard_console, run_command

__all__ = ["Subcommand", "CommandLine", "LOG_LEVELS"]

LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR")


@dataclass(frozen=True)
class Subcommand:
    """One subcommand: its ``name``, the ``module:function`` that registers it, and its ``--help`` line."""

    name: str
    target: str
    help: str

    def register(self, sub: argparse._SubParsersAction) -> None:
        """Import the registration module and add the subcommand's full parser to ``sub``."""
        module, _, function = self.target.partition(":")
        getattr(importlib.import_module(module), function)(sub)


@dataclass(frozen=True)
class CommandLine:
    """A console script: its name, ``--help`` description, version and subcommands."""

    prog: str
    description: str
    version: str
    subcommands: tuple[Subcommand, ...]

    def build_parser(self, command: str | None = None) -> argparse.ArgumentParser:
        """The parser with ``command``'s full subparser, or (None) with every subcommand's (imports them all)."""
        parser, sub = self._parser()
        for subcommand in self.subcommands:
            if command is None or subcommand.name == command:
                subcommand.register(sub)
        return parser

    def listing_parser(self) -> argparse.ArgumentParser:
        """The parser that lists every subcommand by name and help line and imports none: what ``--help``,
        ``--version`` and a mistyped subcommand need."""
        parser, sub = self._parser()
        for subcommand in self.subcommands:
            sub.add_parser(subcommand.name, help=subcommand.help, add_help=False)
        return parser

    def _parser(self) -> tuple[argparse.ArgumentParser, argparse._SubParsersAction]:
        parser = OneLineParser(prog=self.prog, description=self.description)
        parser.add_argument("--version", action="version", version=f"%(prog)s {self.version}")
        parser.add_argument("--log-level", default="INFO", choices=LOG_LEVELS,
                            help="logging threshold (default INFO)")
        return parser, parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def requested_command(self, argv: Sequence[str]) -> str | None:
        """The subcommand ``argv`` names, if it names a known one before any help flag (else None: the list)."""
        names = {subcommand.name for subcommand in self.subcommands}
        tokens = iter(argv)
        for token in tokens:
            if token == "--log-level":
                next(tokens, None)
            elif not token.startswith("-"):
                return token if token in names else None
            elif not token.startswith("--log-level="):
                return None  # --help, --version or a mistake: the list answers
        return None

    def main(self, argv: Sequence[str] | None, known: tuple[type[BaseException], ...] = ()) -> int:
        """Parse ``argv`` (default: the process's), set up logging and run the command; the exit status
        (:func:`~gcs.cli_errors.run_command`, :func:`~gcs.cli_errors.guard_console`)."""
        argv = sys.argv[1:] if argv is None else list(argv)

        def parse_and_run() -> int:
            command = self.requested_command(argv)
            parser = self.listing_parser() if command is None else self.build_parser(command)
            args = parser.parse_args(argv)
            logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
            return run_command(args, known=known)

        return guard_console(self.prog, parse_and_run)
