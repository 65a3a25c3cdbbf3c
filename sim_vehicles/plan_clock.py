"""The simulated vehicles wait for the ground station's plans (``sim-vehicles run --wait-for-plans``).

As a simulator in lockstep with its flight controller (ArduPilot SITL's lockstep
waits for the controller's output before the next physics step), a scene run with
``wait_for_plans`` holds each physics step until the plan of the decision step it
has reached has come: once it has published the reports of step ``k`` it does
not fly past ``k`` before the daemon has published the ``PlanCommand`` of step
``k``. So a command is never
flown later than in the daemon's own loop, whatever the machine's load; against
a real aircraft, which does not wait, the daemon's commands are as old as its
latency makes them (``command_age_ms`` in ``gcs status``).

The wait ends without the plan after :data:`STALE_AFTER_S` of wall time (the
daemon stopped, or planned a later step only): such steps are counted
(``plan_waits_timed_out``). Before the first plan there is nothing to wait for (no
track yet, the daemon plans nothing). :class:`PlanWatch` is the pure rule;
:class:`PlanClock` feeds it from a Zenoh subscription to the plans of this
process's vehicles, drained on the caller's thread.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import msgspec
import zenoh

from protocols.errors import ProtocolError
from protocols.keys import parse_key, plans_selector

__all__ = ["STALE_AFTER_S", "PlanClock", "PlanWatch"]

STALE_AFTER_S = 0.5
"""Wall seconds a held step waits for a plan before it flies on without it."""
CHANNEL_CAPACITY = 4096


class _Stamped(msgspec.Struct):
    """The two fields of a plan the clock needs (the rest is not decoded)."""

    vehicle_id: str
    stamp_ns: int


_decode = msgspec.json.Decoder(_Stamped).decode


@dataclass
class PlanWatch:
    """The newest plan stamp of this process's vehicles, and whether a scene at a stamp must wait for it.

    Reports go out at ``epoch_ns + n period_ns``. A scene at ``stamp_ns`` has published the
    reports of the last such stamp strictly before it, ``r``, and waits while a plan has been
    heard and the newest, over the vehicles (the daemon plans them together), is older than ``r``.
    At ``stamp_ns = r`` itself the reports of ``r`` are still to go, so the plan of the step
    before is enough.
    """

    period_ns: int
    epoch_ns: int = 0
    newest_ns: int | None = None
    plans: int = 0

    def heard(self, stamp_ns: int) -> None:
        """A plan for one of the vehicles, stamped with its decision step."""
        self.plans += 1
        self.newest_ns = stamp_ns if self.newest_ns is None else max(self.newest_ns, stamp_ns)

    def needed_ns(self, stamp_ns: int) -> int:
        """The stamp of the plan a scene at ``stamp_ns`` needs: its last published reports' step."""
        return self.epoch_ns + (stamp_ns - self.epoch_ns - 1) // self.period_ns * self.period_ns

    def behind(self, stamp_ns: int) -> bool:
        """Whether the plans are behind a scene at ``stamp_ns`` (it must wait)."""
        return self.newest_ns is not None and self.newest_ns < self.needed_ns(stamp_ns)


class PlanClock:
    """:class:`PlanWatch` fed from the plans published under ``prefix`` for the vehicles ``own``."""

    def __init__(self, session: zenoh.Session, prefix: str, own: Iterable[str], period_ns: int, epoch_ns: int,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.prefix, self.own, self.clock = prefix, frozenset(own), clock
        self.watch = PlanWatch(period_ns, epoch_ns)
        self._plans = session.declare_subscriber(plans_selector(prefix), zenoh.handlers.FifoChannel(CHANNEL_CAPACITY))

    def poll(self) -> None:
        """Take in the plans received since the last poll."""
        while (sample := self._plans.try_recv()) is not None:
            try:
                if parse_key(str(sample.key_expr), self.prefix).ident not in self.own:
                    continue
                plan = _decode(sample.payload.to_bytes())
            except (ProtocolError, msgspec.DecodeError):
                continue  # not a plan this clock can read
            self.watch.heard(plan.stamp_ns)

    def behind(self, stamp_ns: int) -> bool:
        """Poll, then whether a scene at ``stamp_ns`` must wait for a plan."""
        self.poll()
        return self.watch.behind(stamp_ns)

    def close(self) -> None:
        """Withdraw the subscription."""
        self._plans.undeclare()
