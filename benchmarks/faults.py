"""Fault injection for ``gcs-bench soak``: bad Zenoh samples (the muted MAVLink links are
:class:`sim_vehicles.radio_link.UdpRelay`).

:class:`Injector` puts deliberately bad samples under the daemon's keys, each
kind meant for one rejection: random bytes (``malformed``), a wrong encoding
(``encoding``), a copy of a sample already sent (``duplicate``), a report
older than any open decision step but inside the ingest window (``late``),
one older than the window (``stale``), one from the future (``future``), one
from a vehicle outside the roster (``unknown_vehicle``). Whatever the
daemon makes of each, it must count it: the soak checks that every sample on
the wire was accepted or rejected by reason.
"""

from __future__ import annotations

import threading
from collections import Counter, deque
from collections.abc import Callable

import msgspec
import numpy as np
import zenoh

from protocols.codec import decode, encode
from protocols.errors import ProtocolError
from protocols.keys import report_key
from protocols.messages import SensorReport

__all__ = ["Injector", "INJECTIONS"]

NS_PER_S = 1_000_000_000
REMEMBERED = 1024
"""Injected payloads remembered, so that the observer's copy of one is not taken for a vehicle's report."""
INJECTIONS = ("malformed", "encoding", "duplicate", "late", "stale", "future", "unknown_vehicle")


class Injector:
    """Puts bad samples on a Zenoh session (reliable, ``BLOCK``), learning real ones from ``observe``.

    ``observe(key, payload, encoding)`` is called with samples seen on the wire
    (the soak's observer); the injector keeps the latest report of each vehicle,
    to copy (``duplicate``) or to age (``late``, ``stale``, ``future``).
    """

    def __init__(self, session: zenoh.Session, prefix: str, rng: np.random.Generator, step_s: float) -> None:
        self.session, self.prefix, self.rng, self.step_s = session, prefix, rng, step_s
        self.latest: dict[str, tuple[str, bytes, str]] = {}
        self.newest_ns: int | None = None
        """The newest stamp of a vehicle's report seen (what the daemon's ``future`` check counts from)."""
        self.counts: Counter = Counter()
        self._lock = threading.Lock()
        self._ours: set[bytes] = set()  # what we put (the observer sees it too): never copied or aged again
        self._order: deque[bytes] = deque()

    def observe(self, key: str, payload: bytes, encoding: str) -> int | None:
        """A sample seen on the wire: a vehicle's valid report (not one of ours) is remembered; its stamp."""
        if not key.endswith("/report") or "SensorReport" not in encoding:
            return None
        with self._lock:
            if payload in self._ours:
                return None
        try:
            report = decode(payload, encoding, SensorReport)
        except ProtocolError:
            return None
        with self._lock:
            self.latest[key] = (key, payload, encoding)
            self.newest_ns = report.stamp_ns if self.newest_ns is None else max(self.newest_ns, report.stamp_ns)
        return report.stamp_ns

    def _put(self, key: str, payload: bytes, encoding: str) -> None:
        with self._lock:
            if len(self._order) >= REMEMBERED:
                self._ours.discard(self._order.popleft())
            self._ours.add(payload)
            self._order.append(payload)
        self.session.put(key, payload, encoding=zenoh.Encoding(encoding),
                         congestion_control=zenoh.CongestionControl.BLOCK)

    def _aged(self, report: SensorReport, seconds: float) -> tuple[bytes, str]:
        return encode(msgspec.structs.replace(report, stamp_ns=report.stamp_ns + round(seconds * NS_PER_S)))

    def inject(self, kind: str) -> bool:
        """Put one sample of ``kind`` (see :data:`INJECTIONS`); False when no real report was seen yet."""
        with self._lock:
            seen = list(self.latest.values())
        if not seen:
            return False
        key, payload, encoding = seen[int(self.rng.integers(len(seen)))]
        report = decode(payload, encoding, SensorReport)
        if kind == "malformed":
            self._put(key, self.rng.bytes(int(self.rng.integers(1, 200))), encoding)
        elif kind == "encoding":
            self._put(key, payload, "text/plain")
        elif kind == "duplicate":
            self._put(key, payload, encoding)
        elif kind == "late":  # a new stamp (between two of the vehicle's) in a step long released: ingest takes it
            self._put(key, *self._aged(report, -7.6 * self.step_s))
        elif kind == "stale":
            self._put(key, *self._aged(report, -30.0 * self.step_s))
        elif kind == "future":  # from the newest on the wire: a vehicle killed a while ago has an old latest
            ahead_s = (self.newest_ns - report.stamp_ns) / NS_PER_S + 120.0
            self._put(key, *self._aged(report, ahead_s))
        elif kind == "unknown_vehicle":
            stranger = msgspec.structs.replace(report, vehicle_id="intruder")
            self._put(report_key("intruder", self.prefix), *encode(stranger))
        else:
            raise ValueError(f"unknown injection {kind!r}; expected one of {', '.join(INJECTIONS)}")
        self.counts[kind] += 1
        return True


def every_kind(rng: np.random.Generator) -> Callable[[], str]:
    """A random injection kind each call."""
    return lambda: INJECTIONS[int(rng.integers(len(INJECTIONS)))]
