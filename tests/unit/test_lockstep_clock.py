"""The lockstep clock's bookkeeping (:class:`sim_vehicles.lockstep.PeerClock`) on scripted samples, no network."""

from __future__ import annotations

from collections import deque
from types import SimpleNamespace

import zenoh

from protocols.codec import encode
from protocols.keys import alive_key, report_key
from protocols.messages import SensorReport
from sim_vehicles.lockstep import MAX_JUMP_NS, PeerClock

S = 1_000_000_000


class _Channel:
    """A subscription's FIFO channel, filled by the test."""

    def __init__(self) -> None:
        self.items: deque = deque()

    def try_recv(self):
        return self.items.popleft() if self.items else None

    def undeclare(self) -> None:
        pass


class _Session:
    def __init__(self) -> None:
        self.reports, self.tokens = _Channel(), _Channel()

    def declare_subscriber(self, _selector, _handler):
        return self.reports

    def liveliness(self):
        return SimpleNamespace(declare_subscriber=lambda _selector, _handler, history: self.tokens)


def _report(session: _Session, vehicle: str, stamp_ns: int) -> None:
    payload, _ = encode(SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=(0.0, 0.0, 200.0)))
    session.reports.items.append(SimpleNamespace(key_expr=report_key(vehicle), payload=SimpleNamespace(
        to_bytes=lambda: payload)))


def _token(session: _Session, vehicle: str, alive: bool) -> None:
    kind = zenoh.SampleKind.PUT if alive else zenoh.SampleKind.DELETE
    session.tokens.items.append(SimpleNamespace(key_expr=alive_key(vehicle), kind=kind))


def _clock() -> tuple[PeerClock, _Session, list[float]]:
    session, now = _Session(), [0.0]
    return PeerClock(session, "gcs", ["uav1"], report_period_s=0.05, clock=lambda: now[0]), session, now


def test_only_other_live_vehicles_that_report_are_waited_for() -> None:
    clock, session, now = _clock()
    _token(session, "uav1", True)  # its own vehicle: never waited for
    _token(session, "uav2", True)
    _report(session, "uav1", 3 * S)
    _report(session, "uav3", 1 * S)  # no token (yet): not waited for
    clock.poll()
    assert clock.slowest_ns() is None  # uav2 is alive but has not reported
    _report(session, "uav2", 5 * S)
    clock.poll()
    assert (clock.slowest_ns(), clock.middle_ns()) == (5 * S, 5 * S)
    assert clock.ahead(6 * S + 1, S) and not clock.ahead(6 * S, S)  # more than one report ahead holds
    now[0] = clock.stale_after_s + 0.1  # uav2 stopped reporting with its token up: not waited for any more
    assert clock.slowest_ns() is None


def test_a_stray_report_does_not_move_a_vehicles_clock_unless_the_next_agrees() -> None:
    clock, session, _ = _clock()
    _token(session, "uav2", True)
    for stamp in (4 * S, 5 * S, 5 * S + MAX_JUMP_NS + 2 * S, 6 * S):  # a spoofed sample far ahead, then on time
        _report(session, "uav2", stamp)
    clock.poll()
    assert clock.slowest_ns() == 6 * S
    _token(session, "uav2", False)  # killed: not waited for
    clock.poll()
    assert clock.slowest_ns() is None
    _token(session, "uav2", True)  # restarted; the first sample seen is a stray half a minute back
    for stamp in (50 * S - MAX_JUMP_NS - 10 * S, 50 * S, 51 * S):
        _report(session, "uav2", stamp)
    clock.poll()
    assert clock.slowest_ns() == 51 * S  # two reports agreed: the clock was the stray


def test_a_joining_process_starts_from_the_median_not_from_one_vehicle_ahead() -> None:
    clock, session, _ = _clock()
    for vehicle, stamp in (("uav2", 10), ("uav3", 11), ("uav4", 30)):
        _token(session, vehicle, True)
        _report(session, vehicle, stamp * S)
    clock.poll()
    assert (clock.slowest_ns(), clock.middle_ns()) == (10 * S, 11 * S)
