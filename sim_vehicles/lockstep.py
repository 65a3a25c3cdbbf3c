"""One clock for simulated vehicles flown by several processes (``sim-vehicles run --lockstep``).

Each process paces its scene against the wall clock (``elapsed / rate``); on a
machine that cannot give every process the CPU it needs, one falls behind the
others, and once it is further behind than the ground station's reorder window
its reports come after their decision step closed (``rejected.late``). With
``--lockstep`` a process also watches the other vehicles' reports under its
prefix (:class:`PeerClock`) and holds its scene while it is more than one
report period ahead of the slowest of them: the run's vehicles stay within one
report of each other, so a run that cannot keep its rate slows down as a whole
instead of coming apart.

The vehicles waited for are those whose liveliness token is up and whose
newest report arrived within :meth:`PeerClock.stale_after_s` of wall time: a
killed process's token goes within milliseconds, a process that stopped
reporting without withdrawing its token (stopped, or stuck) is not waited for
after that long, and a restarted one counts again from its first report. A
report far from its vehicle's clock (:data:`MAX_JUMP_NS`) is taken for a stray
sample, unless the next agrees with it.
Nothing here runs on Zenoh's threads: the subscriptions deliver into FIFO
channels that :meth:`PeerClock.poll` drains.

Processes started at once start their clocks together with
:func:`wait_for_vehicles` (``sim-vehicles run --start-with``): each holds its
clock at zero until the other processes' vehicles have their tokens up, however
long the machine takes to start them, and the last one up starts them all
within a token's trip through the router.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable

import msgspec
import zenoh

from protocols.errors import ProtocolError
from protocols.keys import alive_selector, parse_key, reports_selector

__all__ = ["PeerClock", "wait_for_vehicles", "STALE_AFTER_S", "CHANNEL_CAPACITY", "MAX_JUMP_NS", "NOTE_EVERY_S"]

log = logging.getLogger(__name__)

STALE_AFTER_S = 2.0
"""Wall seconds without a report after which a vehicle whose token is up is no longer waited for (at least;
three report periods of wall time when those are longer)."""
CHANNEL_CAPACITY = 4096
"""Samples each subscription holds between two polls."""
MAX_JUMP_NS = 20 * 1_000_000_000
"""A report stamped further than this from its vehicle's clock is a stray (a replayed or spoofed sample: the
soak injects some, a minute ahead or half a minute back) and is not taken for the vehicle's time, unless the
vehicle's next report agrees with it (then the clock was the stray, and moves there)."""
NOTE_EVERY_S = 10.0
"""Wall seconds between two log lines naming the vehicles :func:`wait_for_vehicles` still waits for."""


class _Stamped(msgspec.Struct):
    """The two fields of a report the clock needs (the rest is not decoded)."""

    vehicle_id: str
    stamp_ns: int


_decode = msgspec.json.Decoder(_Stamped).decode


class PeerClock:
    """The newest report stamp of every other live vehicle under ``prefix``; see the module docstring.

    Parameters
    ----------
    session : zenoh.Session
    prefix : str
    own : iterable of vehicle ids
        This process's vehicles, never waited for.
    report_period_s : float
        Wall seconds between two reports of a vehicle (``1 / (report_rate_hz * rate)``).
    clock : callable
        Wall clock (monotonic seconds).
    """

    def __init__(self, session: zenoh.Session, prefix: str, own: Iterable[str], report_period_s: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.prefix, self.own, self.clock = prefix, frozenset(own), clock
        self.stale_after_s = max(STALE_AFTER_S, 3.0 * report_period_s)
        self.alive: set[str] = set()
        self.newest_ns: dict[str, int] = {}
        self.heard_s: dict[str, float] = {}
        self._last_ns: dict[str, int] = {}
        self._reports = session.declare_subscriber(reports_selector(prefix),
                                                   zenoh.handlers.FifoChannel(CHANNEL_CAPACITY))
        self._tokens = session.liveliness().declare_subscriber(
            alive_selector(prefix), zenoh.handlers.FifoChannel(CHANNEL_CAPACITY), history=True)

    def _vehicle(self, key: str) -> str | None:
        try:
            ident = parse_key(key, self.prefix).ident
        except ProtocolError:
            return None
        return None if ident in self.own else ident

    def poll(self) -> None:
        """Take in the liveliness changes and reports received since the last poll."""
        while (sample := self._tokens.try_recv()) is not None:
            vehicle = self._vehicle(str(sample.key_expr))
            if vehicle is None:
                continue
            if sample.kind == zenoh.SampleKind.PUT:
                self.alive.add(vehicle)
            else:  # gone: when it comes back it counts from its first report again
                self.alive.discard(vehicle)
                self.newest_ns.pop(vehicle, None)
                self.heard_s.pop(vehicle, None)
                self._last_ns.pop(vehicle, None)
        now = self.clock()
        while (sample := self._reports.try_recv()) is not None:
            try:
                report = _decode(sample.payload.to_bytes())
            except msgspec.DecodeError:
                continue  # not a report this clock can read: the ground station counts it
            vehicle = report.vehicle_id
            if vehicle in self.own or vehicle not in self.alive:
                continue
            stamp, newest, previous = report.stamp_ns, self.newest_ns.get(vehicle), self._last_ns.get(vehicle)
            self._last_ns[vehicle] = stamp
            if newest is None or abs(stamp - newest) <= MAX_JUMP_NS:
                self.newest_ns[vehicle] = stamp if newest is None else max(newest, stamp)
            elif previous is not None and abs(stamp - previous) <= MAX_JUMP_NS:
                self.newest_ns[vehicle] = max(stamp, previous)  # two reports agree: the clock was the stray
            else:
                continue  # a stray
            self.heard_s[vehicle] = now

    def _current(self) -> list[int]:
        now = self.clock()
        return [stamp for vehicle, stamp in self.newest_ns.items() if now - self.heard_s[vehicle] <= self.stale_after_s]

    def slowest_ns(self) -> int | None:
        """The oldest newest-report stamp among the vehicles waited for (None: nobody to wait for)."""
        stamps = self._current()
        return min(stamps) if stamps else None

    def middle_ns(self) -> int | None:
        """The median (the upper one) of the vehicles' newest report stamps (None: nobody to wait for): where a
        joining process starts, one stray or one vehicle far ahead of the others not moving it."""
        stamps = sorted(self._current())
        return stamps[len(stamps) // 2] if stamps else None

    def ahead(self, stamp_ns: int, lead_ns: int) -> bool:
        """Whether a scene at ``stamp_ns`` is more than ``lead_ns`` ahead of the slowest vehicle waited for."""
        slowest = self.slowest_ns()
        return slowest is not None and stamp_ns - slowest > lead_ns

    def close(self) -> None:
        """Withdraw both subscriptions."""
        self._reports.undeclare()
        self._tokens.undeclare()


def wait_for_vehicles(session: zenoh.Session, prefix: str, vehicles: Iterable[str],
                      keep_waiting: Callable[[], bool], clock: Callable[[], float] = time.monotonic,
                      poll_s: float = 0.01) -> set[str]:
    """Wait until each of ``vehicles`` has its liveliness token up under ``prefix``, while ``keep_waiting()``.

    Tokens already up count (the subscription asks for their history); one withdrawn while waiting is
    waited for again. Every :data:`NOTE_EVERY_S` the vehicles still missing are logged. Returns those
    missing when it stopped: empty once every one is up.
    """
    wanted = set(vehicles)
    if not wanted:
        return set()
    tokens = session.liveliness().declare_subscriber(alive_selector(prefix), zenoh.handlers.FifoChannel(
        CHANNEL_CAPACITY), history=True)
    up: set[str] = set()
    next_note = clock() + NOTE_EVERY_S
    try:
        while True:
            while (sample := tokens.try_recv()) is not None:
                try:
                    vehicle = parse_key(str(sample.key_expr), prefix).ident
                except ProtocolError:
                    continue
                if vehicle is None:  # a key of no vehicle (under the selector, every one names its vehicle)
                    continue
                (up.add if sample.kind == zenoh.SampleKind.PUT else up.discard)(vehicle)
            missing = wanted - up
            if not missing or not keep_waiting():
                return missing
            if clock() >= next_note:
                log.info("waiting for %s to come up", ", ".join(sorted(missing)))
                next_note += NOTE_EVERY_S
            time.sleep(poll_s)
    finally:
        tokens.undeclare()
