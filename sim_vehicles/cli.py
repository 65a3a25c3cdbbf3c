"""The ``sim-vehicles`` command line.

Only subcommands that exist are registered, so ``sim-vehicles --help`` lists
exactly what works; only the one named is imported (:mod:`gcs.cli_commands`).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from gcs.cli_commands import CommandLine, Subcommand
from gcs.config import ScenarioError
from sim_vehicles import __version__

SUBCOMMANDS: tuple[Subcommand, ...] = (
    Subcommand("run", "sim_vehicles.run_command:add_run",
               "fly the scenario's vehicles and target; MAVLink peers and Zenoh publishers"),
    Subcommand("payload", "sim_vehicles.payload_command:add_payload",
               "give an external autopilot's vehicle its reports against the scenario's simulated target"),
)
"""Each subcommand, in the order ``--help`` lists them."""


COMMAND_LINE = CommandLine("sim-vehicles",
                           "Simulated fixed-wing UAVs and the ground target they watch, on MAVLink and Zenoh.",
                           __version__, SUBCOMMANDS)
build_parser = COMMAND_LINE.build_parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sim-vehicles`` console script; returns the exit code (2 for bad input, with one line
    on stderr naming it; 130 on Ctrl-C: :mod:`gcs.cli_errors`)."""
    return COMMAND_LINE.main(argv, known=(ScenarioError,))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
