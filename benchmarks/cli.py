"""The ``gcs-bench`` command line: the benchmarks, a console script of their own beside ``gcs`` and ``sim-vehicles``.

Each benchmark's parser is registered only when it is named (:mod:`gcs.cli_commands`), so that
``gcs-bench --help`` lists them all without loading NumPy; its handler is
:mod:`benchmarks.commands`'s. Bad input is one line and status 2, Ctrl-C status 130
(:mod:`gcs.cli_errors`), as for ``gcs``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from gcs import __version__
from gcs.cli_commands import CommandLine, Subcommand
from gcs.config import ScenarioError

__all__ = ["SUBCOMMANDS", "COMMAND_LINE", "build_parser", "requested_command", "main"]

_TRACKING = "benchmarks.tracking_arguments"
_SYSTEM = "benchmarks.system_arguments"

SUBCOMMANDS: tuple[Subcommand, ...] = (
    Subcommand("estimation", f"{_TRACKING}:add_estimation",
               "DUIF vs FilterPy's UKF: RMSE, RMSE/sqrt(PCRLB), NEES, microseconds per step"),
    Subcommand("urban", f"{_TRACKING}:add_urban",
               "closed loop in the city: observations, RMSE, airspace violations and decision time per planner"),
    Subcommand("aoa", f"{_TRACKING}:add_aoa",
               "zuo2021 bearing-only tracking: estimators, GCRLB-LM vs CRLB vs straight-line planners"),
    Subcommand("skf", f"{_TRACKING}:add_skf",
               "feng2019 Table 1: switching Kalman filter navigation (CF, DF) vs FilterPy's IMM and KF"),
    Subcommand("imm", f"{_TRACKING}:add_imm",
               "CV + coordinated-turn IMM vs the single-model DUIF on the street-following target"),
    Subcommand("multitarget", f"{_TRACKING}:add_multitarget",
               "many ground targets: our GNN and JPDA (Gaussian and on the roads) vs Stone Soup's, GOSPA, track "
               "scores, ms per scan"),
    Subcommand("sharing", f"{_TRACKING}:add_sharing",
               "three UAVs shared between many ground targets: the summed objective, assignment, fixed orbits"),
    Subcommand("scale", f"{_TRACKING}:add_scale",
               "the many-target loop's decision time, ingest rate and memory for 1-20 targets and 3-10 UAVs"),
    Subcommand("federation", f"{_TRACKING}:add_federation",
               "several daemons with their teams, sharing tracks, against one central daemon"),
    Subcommand("roads", f"{_TRACKING}:add_roads",
               "the road trackers against the scenario's estimator, open loop, paired seeds"),
    Subcommand("daemon", f"{_SYSTEM}:add_daemon",
               "the daemon over Zenoh: report-to-command latency and the highest report rate with no loss"),
    Subcommand("replay", f"{_SYSTEM}:add_replay", "gcs replay --process speed in multiples of real time (goal 1000x)"),
    Subcommand("livemap", f"{_SYSTEM}:add_livemap",
               "what the live map costs the daemon's loop: per message and per snapshot"),
    Subcommand("soak", f"{_SYSTEM}:add_soak",
               "the whole ground station for a long run with random faults: nothing lost, no crash, memory"),
    Subcommand("autopilots", f"{_SYSTEM}:add_autopilots",
               "the daemon's steering flown by each autopilot personality: course error, seen, RMSE"),
    Subcommand("demo", f"{_SYSTEM}:add_demo",
               "gcs demo at its default settings against the same scenario and seeds in one process"),
)
"""Each benchmark, in the order ``--help`` lists them."""

COMMAND_LINE = CommandLine("gcs-bench", "Benchmarks of the tracking ground station: the papers' experiments "
                           "reproduced, peers measured in the same run, and speed. Each prints its tables (progress "
                           "on stderr) and can write --json; most take --plots DIR (PNG plots and the tables in "
                           "markdown).", __version__, SUBCOMMANDS)
build_parser = COMMAND_LINE.build_parser
requested_command = COMMAND_LINE.requested_command


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``gcs-bench`` console script; returns the process exit code."""
    return COMMAND_LINE.main(argv, known=(ScenarioError,))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
