"""The daemon loop's garbage collection: what the loop builds is frozen as it goes, and collected in full rarely.

The heap built before the loop is frozen (``gc.freeze``): CPython's full garbage
collection walks every tracked object, and after the imports (SciPy, pymavlink,
Zenoh, ...) that is some 75,000 of them and 40-60 ms of CPU, several times a
minute at thousands of reports a second, holding every report and command behind
it. Nothing built before the loop becomes cyclic garbage while it runs. What the
loop keeps (records, estimates, registry entries) is frozen too, every
:data:`FREEZE_EVERY_S`: at 100 vehicles its older-generation collections otherwise
took 5-11 ms, a few times a minute. The loop makes no cyclic garbage (none was
collected over whole ``gcs-bench daemon`` runs); in case some path does, the young
generations are collected before each freeze, and every :data:`FULL_COLLECT_EVERY_S`
the loop collects everything it froze: when idle, or after twice that if never idle.
The heap is given back to the collector (``gc.unfreeze``) when the loop ends.
"""

from __future__ import annotations

import gc
import math

__all__ = ["HeapFreezer", "FREEZE_EVERY_S", "FULL_COLLECT_EVERY_S"]

FREEZE_EVERY_S = 1.0
"""How often the loop hands what it has built so far to ``gc.freeze``."""
FULL_COLLECT_EVERY_S = 600.0
"""How often the loop, when idle, collects everything it froze (any cyclic garbage; the imports' heap too);
a loop never idle does it after twice this."""


class HeapFreezer:
    """The garbage-collection policy of one run of the loop (see the module docstring); times in loop seconds."""

    def __init__(self) -> None:
        self._next_freeze_s = math.inf
        self._next_full_collect_s = math.inf

    def start(self, now_s: float) -> None:
        """Freeze the heap built before the loop (the imports, the world, the tracker)."""
        gc.freeze()
        self._next_freeze_s = now_s
        self._next_full_collect_s = now_s + FULL_COLLECT_EVERY_S

    def turn(self, now_s: float, busy: bool) -> None:
        """After a pass of the loop (``busy``: it handled something): freeze what is due, collect in full when due
        and idle (or long overdue)."""
        if now_s >= self._next_freeze_s:
            gc.collect(1)  # the young generations' cycles, if any, before their survivors are frozen
            gc.freeze()
            self._next_freeze_s = now_s + FREEZE_EVERY_S
        full = self._next_full_collect_s
        if now_s >= full and (not busy or now_s >= full + FULL_COLLECT_EVERY_S):
            gc.unfreeze()
            gc.collect()
            gc.freeze()
            self._next_full_collect_s = now_s + FULL_COLLECT_EVERY_S

    @staticmethod
    def stop() -> None:
        """Give the heap back to the collector (the loop ended)."""
        gc.unfreeze()
