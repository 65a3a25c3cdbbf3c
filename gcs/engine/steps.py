"""Grouping sensor reports into decision steps by their stamps, with a documented reorder window.

Decision step ``k`` is the stamp ``T_k = T_0 + k * step``; a report belongs to
the step nearest its stamp, ``k = round((stamp - T_0) / step)``. ``T_0`` is the
earliest stamp filed before the first step is released (so it does not depend
on which vehicle's first report happened to arrive first).

**Reorder window.** A step is *open* from its first report until it is
released; every report that arrives while its step is open is used, whatever
the order in which the reports came, and a released step's reports are handed
on in stamp order (ties by vehicle id, then sequence number), so arrival order
never changes a result. Steps are released in index order, each once:

* by **timeout**, ``max_wait_s`` of wall time after half the vehicles it
  waits for (at least one) have reported for it (a vehicle may have died
  without its liveliness token being withdrawn yet), and at the latest
  :data:`HOLD_WAITS` ``max_wait_s`` (5 s) after its first report. Counting
  from half the vehicles rather than from the first report keeps one vehicle
  whose clock runs ahead of the others (its reports come early) from cutting
  their wait short; the first step of a run always waits for the timeout;
* or, earlier, when **complete**: every vehicle the daemon expects (those
  alive, less those whose latest two reports ingest refused for their stamps: see
  :attr:`gcs.engine.ingest.Ingest.off_clock`) has a report in the step, or has already reported for step
  ``k + 1 + reorder_steps`` or later (it skipped the step and is not waited
  for), and the step follows the last released one directly (after a step
  that nobody reported for, the next step waits for its timeout).

**Navigation.** With the daemon's own navigation (``--navigation skf``,
:mod:`gcs.engine.navigation`) a step also waits, within the same window and
timeout, for the nav reports it needs: complete means, besides the above, that
every expected vehicle that sends nav (:meth:`StepAssembler.add_nav`) has sent
one stamped ``>= T_k``. A vehicle's messages arrive in the order it sent them
(Zenoh keeps a publisher's order), so every one of its nav reports stamped
``<= T_k`` is in by then and the navigation filter can be advanced to ``T_k``
before the step is fused. A vehicle *sends nav* for step ``k`` when its newest
nav report is stamped after ``T_{k-1}`` (at least one a step); one that never
sent nav, or whose nav stopped a step or more before (a GPS/INS feed lost, or a
source that sent one nav report for its heading and no more), is not waited
for, nor one that has reported for step ``k + 1 + reorder_steps``. A nav report that comes after its step was released is
late (``rejected.late_nav``, counted by the navigator) and dropped.

So a report is used when it arrives (a) within ``max_wait_s`` (0.5 s) of the
time half the vehicles had reported for its step (within 5 s of the step's
first report), and (b) before its own vehicle's report for
``reorder_steps + 1`` (2) steps later: one vehicle's report may swap with its
next step's. With stamps ``step`` apart sent ``D`` wall seconds apart (``D =
step / rate``) and jitter below ``D / 4``, a report delayed by less than
``min(max_wait_s - D / 2, 1.5 D)`` is inside the window whatever the other
reports do. A report for a step already released is outside the window: it
is counted as ``rejected.late`` and dropped, never used out of order.

Because membership depends only on stamps, live, replayed and in-process runs
group the same reports into the same steps whatever the arrival timing, as
long as every report arrives within the window.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field

from protocols.messages import SensorReport

__all__ = ["StepAssembler", "ReadyStep", "REORDER_STEPS", "HOLD_WAITS"]

REORDER_STEPS = 1
"""How many later steps a vehicle may have reported for before its report for a step is no longer waited for."""
HOLD_WAITS = 10
"""A step is released at the latest this many ``max_wait_s`` after its first report, quorum or not."""


@dataclass(frozen=True)
class ReadyStep:
    """One decision step: its stamp and the reports that belong to it, in stamp order."""

    index: int
    stamp_ns: int
    reports: tuple[SensorReport, ...]


_NEVER = -(2**62)
"""The latest step of a vehicle that has not reported."""


def _stamp_order(report: SensorReport) -> tuple[int, str, int]:
    return report.stamp_ns, report.vehicle_id, report.seq


@dataclass
class StepAssembler:
    """Buckets reports by decision step; see the module docstring."""

    step_ns: int
    max_wait_s: float = 0.5
    origin_ns: int | None = None
    reorder_steps: int = REORDER_STEPS
    counters: Counter[str] = field(default_factory=Counter)
    _open: dict[int, list[SensorReport]] = field(default_factory=dict)
    _arrived_s: dict[int, dict[str, float]] = field(default_factory=dict)
    _latest_step: dict[str, int] = field(default_factory=dict)
    _latest_nav_ns: dict[str, int] = field(default_factory=dict)
    _next: int | None = None

    def index_of(self, stamp_ns: int) -> int:
        """Step index of a stamp (the origin is set by the first report)."""
        if self.origin_ns is None:
            self.origin_ns = stamp_ns
        return round((stamp_ns - self.origin_ns) / self.step_ns)

    def stamp_of(self, index: int) -> int:
        """Stamp of step ``index``."""
        assert self.origin_ns is not None
        return self.origin_ns + index * self.step_ns

    @property
    def open_steps(self) -> int:
        """Steps holding reports, not yet released."""
        return len(self._open)

    def add(self, report: SensorReport, now_s: float) -> bool:
        """File a report; False (and counted as ``rejected.late``) when its step was already released."""
        if self._next is None and self.origin_ns is not None and report.stamp_ns < self.origin_ns and self._open:
            self._reanchor(report.stamp_ns)
        index = self.index_of(report.stamp_ns)
        if self._next is not None and index < self._next:
            self.counters["rejected.late"] += 1
            return False
        self._open.setdefault(index, []).append(report)
        self._arrived_s.setdefault(index, {}).setdefault(report.vehicle_id, now_s)
        self._latest_step[report.vehicle_id] = max(index, self._latest_step.get(report.vehicle_id, index))
        return True

    def add_nav(self, vehicle_id: str, stamp_ns: int) -> None:
        """Note an accepted nav report: from now on the vehicle's steps wait for its nav (module docstring)."""
        self._latest_nav_ns[vehicle_id] = max(stamp_ns, self._latest_nav_ns.get(vehicle_id, stamp_ns))

    def _reanchor(self, origin_ns: int) -> None:
        """Before the first release: move the origin to an earlier stamp and file the open reports again."""
        reports = [(r, self._arrived_s[i][r.vehicle_id]) for i, rs in self._open.items() for r in rs]
        self.origin_ns = origin_ns
        self._open, self._arrived_s, self._latest_step = {}, {}, {}
        for report, seen_s in sorted(reports, key=lambda item: item[1]):
            self.add(report, seen_s)

    def _complete(self, index: int, expected: AbstractSet[str]) -> bool:
        """Whether step ``index`` waits for nothing more: every expected vehicle has reported for it (and,
        if it sends nav, sent nav stamped at or after it) or has reported for a step past the reorder window."""
        if index != self._next:  # the first step, or a gap before it: wait for the timeout
            return False
        reported, latest = self._arrived_s[index], self._latest_step
        past_window = index + self.reorder_steps  # a vehicle that reported after this is not waited for
        for vehicle_id in expected - reported.keys():
            if latest.get(vehicle_id, _NEVER) <= past_window:
                return False
        stamp = self.stamp_of(index)
        since = stamp - self.step_ns  # a vehicle sends nav when its newest nav is after the step before
        for vehicle_id, nav_ns in self._latest_nav_ns.items():
            if since < nav_ns < stamp and vehicle_id in expected and latest.get(vehicle_id, _NEVER) <= past_window:
                return False  # its report is in, its nav for the step not yet
        return True

    def deadline_s(self, index: int, expected: AbstractSet[str]) -> float:
        """When step ``index`` times out: ``max_wait_s`` after half the expected vehicles (at least one)
        have reported for it, and at the latest :data:`HOLD_WAITS` ``max_wait_s`` after its first report."""
        arrived = self._arrived_s[index]
        first = min(arrived.values())
        times = sorted(t for v, t in arrived.items() if v in expected) if expected else [first]
        quorum = max(1, (len(expected) + 1) // 2)
        hold = first + HOLD_WAITS * self.max_wait_s
        return hold if len(times) < quorum else min(times[quorum - 1] + self.max_wait_s, hold)

    def ready(self, expected: AbstractSet[str], now_s: float, timeouts: bool = True) -> list[ReadyStep]:
        """Release, in order, every step that is complete or (unless not ``timeouts``) has waited long
        enough. The daemon's loop asks without timeouts while it still holds received reports to file:
        a step's missing report may be among them."""
        out = []
        while self._open:
            index = min(self._open)
            complete = self._complete(index, expected)
            if not complete and (not timeouts or now_s < min(self._arrived_s[index].values()) + self.max_wait_s
                                 or now_s < self.deadline_s(index, expected)):  # (no deadline comes sooner)
                break
            if not complete:
                self.counters["steps_released_by_timeout"] += 1
            reports = sorted(self._open.pop(index), key=_stamp_order)
            out.append(ReadyStep(index, self.stamp_of(index), tuple(reports)))
            del self._arrived_s[index]
            self._next = index + 1
        return out
