"""What every ``gcs-bench`` benchmark's parser shares: argument types, the checks of ``--json`` and ``--plots``
before a benchmark runs, and its registration.

The parsers themselves are :mod:`benchmarks.tracking_arguments` (the papers' experiments and the
trackers) and :mod:`benchmarks.system_arguments` (the ground station as a system); each handler is
:mod:`benchmarks.commands`'s.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from gcs.cli_errors import UsageError, writable_file

__all__ = ["PLOTS_HELP", "check_outputs", "outputs_checked", "finish", "positive_int", "positive_float",
           "non_negative_int", "probability", "non_negative_float"]

PLOTS_HELP = "write PNG plots and a markdown table (<benchmark>.md) into DIR"


def check_outputs(args: argparse.Namespace) -> None:
    """UsageError unless --json can be written and --plots DIR is a folder or can be made; the scenario loads."""
    writable_file(getattr(args, "json", None), "--json")
    plots = getattr(args, "plots", None)
    if plots is not None and plots.exists() and not plots.is_dir():
        raise UsageError(f"--plots {plots}: not a folder")
    if getattr(args, "scenario", None) is not None:
        from gcs.scenarios import load_scenario

        load_scenario(args.scenario)


def outputs_checked(handler: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """Check --json and --plots DIR (made here) before the benchmark runs, not after an hour of it."""

    def checked(args: argparse.Namespace) -> int:
        check_outputs(args)
        plots = getattr(args, "plots", None)
        if plots is not None:
            try:
                plots.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise UsageError(f"--plots {plots}: {error.strerror or error}") from None
        return handler(args)

    return checked


def finish(parser: argparse.ArgumentParser) -> None:
    """The benchmark's input check, and its name in errors (``gcs-bench soak: error: ...``)."""
    parser.set_defaults(check=check_outputs, command_prog=parser.prog)


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def probability(text: str) -> float:
    value = float(text)
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a probability in (0, 1], got {text}")
    return value


def non_negative_float(text: str) -> float:
    value = float(text)
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value
