"""What ``gcs run`` tells its operator as it flies: a line every :data:`REPORT_EVERY_S` of flight, and a last line
when it stops that says what it did.

:class:`FlightReport` is the daemon's ``on_step`` hook (each decision step's record, in
order): it counts the steps and those in which some vehicle saw the target, and when the
steps' stamps (the vehicles' clock: simulation time against simulated vehicles) have
advanced another :data:`REPORT_EVERY_S` it logs :func:`~gcs.daemon.status_text.flight_line`
of the daemon's status.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from gcs.engine.records import StepRecord
from gcs.daemon.status_text import flight_line
from protocols.messages import DaemonStatus

__all__ = ["FlightReport", "REPORT_EVERY_S"]

log = logging.getLogger(__name__)

REPORT_EVERY_S = 30.0
"""Seconds of flight (the steps' stamps) between two lines."""
NS_PER_S = 1_000_000_000


class FlightReport:
    """Counts the decision steps and logs a line of the daemon's status every :data:`REPORT_EVERY_S` of flight.

    ``status`` gives the daemon's status now; ``step_s`` is the scenario's decision period."""

    def __init__(self, status: Callable[[], DaemonStatus], step_s: float, every_s: float = REPORT_EVERY_S) -> None:
        self.status, self.step_s, self.every_ns = status, step_s, round(every_s * NS_PER_S)
        self.steps = self.seen = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self._next_ns = 0

    @property
    def flown_s(self) -> float:
        """Seconds of the vehicles' time from the first decision step to the last."""
        return 0.0 if self.first_ns is None or self.last_ns is None else (self.last_ns - self.first_ns) / NS_PER_S

    def __call__(self, record: StepRecord) -> None:
        self.steps += 1
        self.seen += any(record.seen.values())
        if self.first_ns is None:
            self.first_ns, self._next_ns = record.stamp_ns, record.stamp_ns + self.every_ns
        self.last_ns = max(record.stamp_ns, self.last_ns or record.stamp_ns)
        if record.stamp_ns >= self._next_ns:
            self._next_ns += self.every_ns * ((record.stamp_ns - self._next_ns) // self.every_ns + 1)
            log.info("%s", flight_line(self.status(), self.flown_s, self.steps, self.seen, self.step_s))

    def stopped(self, counters: dict[str, int], mavlink: bool) -> str:
        """The last line: the steps fused and planned and what was sent, from the daemon's ``counters``."""
        plans = counters.get("decisions", 0)
        if not self.steps:
            done = "no decision step (no vehicle report came in)"
        else:
            done = (f"{self.steps} decision steps fused over {self.flown_s:.0f} s of flight, the target seen in "
                    f"{self.seen}; {plans} plans made")
            idle = counters.get("steps_without_vehicles", 0)
            if idle:
                done += f" ({idle} steps had no vehicle alive to plan for)"
        if not mavlink:
            sent = "MAVLink off: plans published over Zenoh, no vehicle commanded"
        else:
            steering = counters.get("mavlink.heading_commands", 0) + counters.get("mavlink.carrots", 0)
            sent = f"{steering} steering commands sent over MAVLink"
        return f"daemon stopped: {done}; {sent}"
