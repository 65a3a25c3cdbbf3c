"""Grouping sensor reports into decision steps by their stamps.

Decision step ``k`` is the stamp ``T_k = T_0 + k * step`` (``T_0`` is the first
report's stamp); a report belongs to the step nearest its stamp,
``k = round((stamp - T_0) / step)``. A step is **ready** when every vehicle the
daemon expects has reported for it or a later step, or when ``max_wait_s`` of
wall time has passed since its first report (a vehicle may have died without
its liveliness token being withdrawn yet). Steps are released in order, each
once; a report for a step already released is late and is counted, not used.

Because membership depends only on stamps, live, replayed and in-process runs
group the same reports into the same steps whatever the arrival timing, as long
as nothing arrives later than ``max_wait_s``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from protocols.messages import SensorReport

__all__ = ["StepAssembler", "ReadyStep"]


@dataclass(frozen=True)
class ReadyStep:
    """One decision step: its stamp and the reports that belong to it, in arrival order."""

    index: int
    stamp_ns: int
    reports: tuple[SensorReport, ...]


@dataclass
class StepAssembler:
    """Buckets reports by decision step; see the module docstring."""

    step_ns: int
    max_wait_s: float = 0.5
    origin_ns: int | None = None
    counters: Counter = field(default_factory=Counter)
    _open: dict[int, list[SensorReport]] = field(default_factory=dict)
    _first_seen_s: dict[int, float] = field(default_factory=dict)
    _latest_step: dict[str, int] = field(default_factory=dict)
    _next: int = 0

    def index_of(self, stamp_ns: int) -> int:
        """Step index of a stamp (the origin is set by the first report)."""
        if self.origin_ns is None:
            self.origin_ns = stamp_ns
        return round((stamp_ns - self.origin_ns) / self.step_ns)

    def stamp_of(self, index: int) -> int:
        """Stamp of step ``index``."""
        assert self.origin_ns is not None
        return self.origin_ns + index * self.step_ns

    def add(self, report: SensorReport, now_s: float) -> bool:
        """File a report; False (and counted as ``rejected.late``) when its step was already released."""
        index = self.index_of(report.stamp_ns)
        if index < self._next:
            self.counters["rejected.late"] += 1
            return False
        self._open.setdefault(index, []).append(report)
        self._first_seen_s.setdefault(index, now_s)
        self._latest_step[report.vehicle_id] = max(index, self._latest_step.get(report.vehicle_id, index))
        return True

    def ready(self, expected: set[str], now_s: float) -> list[ReadyStep]:
        """Release, in order, every step that is complete or has waited long enough."""
        out = []
        while self._open:
            index = min(self._open)
            complete = all(self._latest_step.get(v, -1) >= index for v in expected)
            if not complete and now_s - self._first_seen_s[index] < self.max_wait_s:
                break
            if not complete:
                self.counters["steps_released_by_timeout"] += 1
            out.append(ReadyStep(index, self.stamp_of(index), tuple(self._open.pop(index))))
            del self._first_seen_s[index]
            self._next = index + 1
        return out
