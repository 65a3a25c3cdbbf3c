"""The command-line flags of the engine's options (:class:`~gcs.engine.options.EngineOptions`), shared by
``gcs run``, ``gcs demo`` and ``gcs replay --process``, which decide alike given the same flags."""

from __future__ import annotations

import argparse

from gcs.engine.navigation import NAVIGATION_MODES

__all__ = ["add_acceptance_arguments", "add_navigation_argument"]


def add_acceptance_arguments(parser: argparse.ArgumentParser, scope: str = "") -> None:
    """``--accept-unlisted`` and ``--max-wait``, what the engine accepts and how long a step waits, shared by
    ``gcs run``, ``gcs demo`` and ``gcs replay --process`` (``scope`` prefixes their help)."""
    parser.add_argument("--accept-unlisted", action="store_true",
                        help=scope + "also accept and fuse reports from vehicles outside the scenario's roster "
                                     "(default: rejected and counted as rejected.unknown_vehicle); they are never "
                                     "commanded")
    parser.add_argument("--max-wait", type=float, default=0.5, metavar="S",
                        help=scope + "how long a decision step waits for missing vehicles' reports once half "
                                     "have reported, in seconds of receive time (default 0.5)")


def add_navigation_argument(parser: argparse.ArgumentParser) -> None:
    """``--navigation``, shared by ``gcs run``, ``gcs demo`` and ``gcs replay --process``."""
    parser.add_argument("--navigation", choices=NAVIGATION_MODES, default="auto",
                        help="vehicle positions for fusion: skf runs feng2019's switching Kalman filter on each "
                             "vehicle's NavReports (GPS + INS) and fuses with its covariance; reported takes each "
                             "SensorReport's own position as exact; auto (default): skf when the scenario declares "
                             "GPS-denied zones, else reported")
