"""Helper processes below the priority of the process that starts them: one range, one check, one call.

The daemon's planner process (``gcs run --planner-nice``) and the load process of
``gcs-bench daemon`` (``--load-nice``) lower their own scheduling priority by a
niceness of 0-19 once started. Kept free of heavy imports: the command-line
parsers use it.
"""

from __future__ import annotations

import argparse
import os

__all__ = ["MAX_NICENESS", "check_niceness", "niceness_argument", "lower_priority"]

MAX_NICENESS = 19
"""The largest niceness a process can be lowered by (0 leaves it as it is)."""


def check_niceness(value: int, whose: str) -> int:
    """``value`` if it is a niceness of 0-:data:`MAX_NICENESS`; ValueError naming ``whose`` (e.g. "the planner's")."""
    if not 0 <= value <= MAX_NICENESS:
        raise ValueError(f"{whose} niceness must be 0-{MAX_NICENESS}, got {value!r}")
    return value


def niceness_argument(text: str) -> int:
    """An argparse ``type``: a niceness of 0-:data:`MAX_NICENESS`."""
    value = int(text)
    if not 0 <= value <= MAX_NICENESS:
        raise argparse.ArgumentTypeError(f"must be 0-{MAX_NICENESS}, got {value}")
    return value


def lower_priority(niceness: int) -> int | None:
    """Lower this process's priority by ``niceness`` (where the system has ``nice``); the niceness it
    runs at now, or None where the system has no ``nice``."""
    if not hasattr(os, "nice"):
        return None
    return os.nice(niceness) if niceness > 0 else os.nice(0)
