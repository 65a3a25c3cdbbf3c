"""Validation of everything the ground station receives over Zenoh: accept, or reject with a counted reason.

Every sample goes through :meth:`Ingest.accept`, which returns the decoded
message or ``None``. Rejections are counted under ``rejected.<reason>`` and
logged (the first few of each reason at WARNING, the rest at DEBUG, so a
flood of bad input cannot flood the log); nothing raises. Reasons:

* the codec's (:data:`protocols.REJECT_REASONS`): ``key``, ``encoding``,
  ``unexpected_type``, ``malformed``, ``invalid``, ``oversize``;
* ``id_mismatch``: the message's ``vehicle_id`` differs from its key's;
* ``unknown_vehicle``: not in the scenario's roster (unless ``accept_unlisted``:
  then up to :data:`MAX_UNLISTED` other vehicles are accepted, counted under
  ``accepted.unlisted.<kind>``, and reported by :attr:`Ingest.unlisted`);
* ``implausible``: valid on the wire but absurd here: a position more than
  :data:`MAX_ABS_POSITION_M` from the scenario's origin, a range beyond
  :data:`MAX_RANGE_M`;
* ``duplicate``: the same stamp as an accepted message of the same kind from
  the same source (a message is identified by its source and stamp; ``seq``
  is informational, it starts again when a vehicle restarts);
* ``stale``: a stamp more than :data:`REORDER_WINDOW_NS` older than the
  newest accepted one of the same kind from the same source. Inside that
  window an older stamp is accepted (out-of-order arrival): the step
  assembler (:mod:`gcs.engine.steps`) decides whether a report is still in
  time for its decision step, and the registry keeps the newest navigation;
* ``future``: a stamp more than :data:`MAX_AHEAD_NS` after the newest accepted
  one from anybody (a clock gone wrong must not make that vehicle's later
  reports look old, nor hold the decision steps back);
* ``unknown_target``: truth of more than :data:`MAX_TARGETS` targets;
* ``unexpected_kind``: a key of the key space the daemon does not consume.

Accepted messages are counted under ``accepted.<kind>``. A vehicle's scenario
announcement (:class:`~protocols.messages.VehicleScenario`) is checked against the
daemon's own scenario: one that names another scenario, or the same name with other
settings (another fingerprint, :func:`gcs.config.fingerprint.scenario_fingerprint`),
is logged at WARNING once per scenario and fingerprint, naming both; it is counted
under ``accepted.scenario`` whatever it says (from any vehicle, listed or not: a
vehicle of another scenario's roster is how the mistake shows), and steers nothing.
"""

from __future__ import annotations

import heapq
import logging
from collections import Counter

from gcs.config import Scenario
from gcs.config.fingerprint import scenario_fingerprint
from gcs.engine.events import Arrived
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import ParsedKey, parse_key
from protocols.messages import NavReport, SensorReport, TargetTruth, VehicleScenario

__all__ = ["Ingest", "WARN_FIRST"]

log = logging.getLogger(__name__)

WARN_FIRST = 5
"""Rejections of each reason logged at WARNING before the rest go to DEBUG."""

_CONSUMED: dict[str, type[SensorReport] | type[NavReport] | type[TargetTruth]] = {
    "report": SensorReport, "nav": NavReport, "truth": TargetTruth}
"""The kinds of key the engine consumes, and the message each carries (as :data:`protocols.keys.MESSAGE_TYPE_BY_KIND`)."""
_ACCEPTED = {kind: f"accepted.{kind}" for kind in _CONSUMED}
MAX_AHEAD_NS = 60 * 1_000_000_000
"""How far a stamp may run ahead of the newest accepted one (a minute of data time)."""
MAX_CACHED_KEYS = 4096
"""Parsed keys remembered (a few per vehicle); a flood of made-up keys cannot grow the cache beyond this."""
REORDER_WINDOW_NS = 10 * 1_000_000_000
"""How far (data time) behind a source's newest stamp a message may come and still be accepted; the stamps
inside the window are remembered to recognise duplicates, so older ones cannot be checked and are stale."""
MAX_RECENT = 4096
"""Stamps remembered per source and kind (10 s of a 400 Hz stream); bounds the memory a flood can take."""
OFF_CLOCK_AFTER = 2
"""Reports of a vehicle refused in a row for their stamps before it is taken off the clock: one may be a
stray (a replayed or spoofed sample); a vehicle whose clock has gone wrong sends nothing else."""
MAX_UNLISTED = 64
"""Vehicles outside the roster accepted with ``accept_unlisted`` (the rest are ``unknown_vehicle``)."""
MAX_ABS_POSITION_M = 1_000_000.0
"""Positions (ENU, about the scenario's origin) further than 1000 km east or north are ``implausible``."""
MAX_ABS_ALTITUDE_M = 100_000.0
MAX_RANGE_M = 1_000_000.0
"""Sensor ranges beyond 1000 km are ``implausible``."""
MAX_TARGETS = 16
"""Targets whose (simulated) truth is accepted; more are ``unknown_target`` (bounds the memory per source)."""


class Ingest:
    """Decode and validate samples for a roster of vehicles under a key prefix."""

    def __init__(self, roster: set[str], prefix: str = "gcs", accept_unlisted: bool = False,
                 scenario: Scenario | None = None) -> None:
        """``accept_unlisted``: take reports from vehicles outside the roster too; ``scenario``: the daemon's own,
        which the vehicles' announcements are checked against (None: not checked; see the module docstring)."""
        self.own_scenario = None if scenario is None else (scenario.name, scenario_fingerprint(scenario))
        self.foreign_scenarios: set[tuple[str, str]] = set()
        """The other scenarios (name, fingerprint) vehicles announced, each warned about once."""
        self.roster = set(roster)
        self.prefix = prefix
        self.accept_unlisted = accept_unlisted
        self.unlisted: list[str] = []
        """Vehicles outside the roster accepted so far, in order of arrival (only with ``accept_unlisted``)."""
        self.counters: Counter[str] = Counter()
        self.off_clock: set[str] = set()
        """Vehicles whose latest :data:`OFF_CLOCK_AFTER` reports were rejected for their stamps (``future`` or
        ``stale``: a clock gone wrong): the step assembler does not wait for them until one of their reports
        is accepted again."""
        self._refused_in_a_row: Counter[str] = Counter()
        self._stamps: dict[tuple[str, str], _Recent] = {}
        self._targets: set[str] = set()
        self._keys: dict[str, ParsedKey] = {}
        self._newest_ns: int | None = None

    @property
    def newest_ns(self) -> int | None:
        """The newest stamp accepted from any source (the vehicles' clock: simulation time against
        simulated vehicles); None before the first."""
        return self._newest_ns

    def reject(self, reason: str, detail: str) -> None:
        """Count and log one rejection."""
        name = f"rejected.{reason}"
        self.counters[name] += 1
        level = logging.WARNING if self.counters[name] <= WARN_FIRST else logging.DEBUG
        log.log(level, "rejected (%s): %s", reason, detail)

    def accept(self, received: Arrived) -> SensorReport | NavReport | TargetTruth | VehicleScenario | None:
        """The decoded message if it passes every check, else None (counted and logged)."""
        parsed = self._keys.get(received.key)
        if parsed is None:
            try:
                parsed = parse_key(received.key, self.prefix)
            except ProtocolError as error:
                self.reject(error.reason, str(error))
                return None
            if len(self._keys) < MAX_CACHED_KEYS:
                self._keys[received.key] = parsed
        if parsed.kind == "scenario" and parsed.ident is not None:  # (parse_key names every scenario's vehicle)
            return self._announced(received, parsed.ident)
        expected = _CONSUMED.get(parsed.kind)
        if expected is None:
            self.reject("unexpected_kind", f"{received.key}: the daemon does not consume {parsed.kind!r} keys")
            return None
        try:
            message = decode(received.payload, received.encoding, expected)
        except ProtocolError as error:
            self.reject(error.reason, f"{received.key}: {error}")
            return None
        problem = _implausible(message)
        if problem is not None:
            self.reject("implausible", f"{received.key}: {problem}")
            return None
        if isinstance(message, TargetTruth):
            source = message.target_id
            if ("truth", source) not in self._stamps and len(self._targets) >= MAX_TARGETS:
                self.reject("unknown_target", f"{received.key}: more than {MAX_TARGETS} targets")
                return None
        else:
            source = message.vehicle_id
            if source != parsed.ident:
                self.reject("id_mismatch", f"{received.key}: message says vehicle_id={source!r}")
                return None
            if source not in self.roster and not self._admit_unlisted(source):
                self.reject("unknown_vehicle", f"{received.key}: {source!r} is not in the roster")
                return None
        stamp = message.stamp_ns
        if self._newest_ns is not None and stamp > self._newest_ns + MAX_AHEAD_NS:
            self.reject("future", f"{received.key}: stamp {stamp} is more than "
                                  f"{MAX_AHEAD_NS // 1_000_000_000} s after the newest ({self._newest_ns})")
            self._off_clock(parsed.kind, source)
            return None
        recent = self._stamps.get((parsed.kind, source))
        if recent is None:
            recent = self._stamps[(parsed.kind, source)] = _Recent()
            if parsed.kind == "truth":
                self._targets.add(source)
        verdict = recent.check(stamp)
        if verdict is not None:
            newest = recent.newest
            self.reject(verdict, f"{received.key}: stamp {stamp} " + (
                "was accepted already" if verdict == "duplicate" else
                f"is more than {REORDER_WINDOW_NS / 1e9:g} s older than the newest ({newest})"))
            if verdict == "stale":  # a duplicate says nothing about the vehicle's clock
                self._off_clock(parsed.kind, source)
            return None
        recent.add(stamp)
        if parsed.kind == "report":
            self.off_clock.discard(source)
            self._refused_in_a_row.pop(source, None)
        if self._newest_ns is None or stamp > self._newest_ns:
            self._newest_ns = stamp
        if parsed.kind != "truth" and source not in self.roster:
            self.counters[f"accepted.unlisted.{parsed.kind}"] += 1
        else:
            self.counters[_ACCEPTED[parsed.kind]] += 1
        return message

    def _announced(self, received: Arrived, vehicle_id: str) -> VehicleScenario | None:
        """A vehicle's scenario announcement: decoded, counted, and compared with the daemon's own scenario."""
        try:
            message = decode(received.payload, received.encoding, VehicleScenario)
        except ProtocolError as error:
            self.reject(error.reason, f"{received.key}: {error}")
            return None
        if message.vehicle_id != vehicle_id:
            self.reject("id_mismatch", f"{received.key}: message says vehicle_id={message.vehicle_id!r}")
            return None
        self.counters["accepted.scenario"] += 1
        theirs = (message.scenario, message.fingerprint)
        if self.own_scenario not in (None, theirs) and theirs not in self.foreign_scenarios:
            self.foreign_scenarios.add(theirs)
            log.warning("vehicle %s flies scenario %s (fingerprint %s), but this daemon runs %s (fingerprint %s): "
                        "start the daemon and the vehicles with the same --scenario", vehicle_id, *theirs,
                        *self.own_scenario)
        return message

    def _off_clock(self, kind: str, source: str) -> None:
        """A report refused for its stamp: after :data:`OFF_CLOCK_AFTER` in a row its vehicle's clock has gone
        wrong (taken back by an accepted one)."""
        if kind == "report":
            self._refused_in_a_row[source] += 1
            if self._refused_in_a_row[source] >= OFF_CLOCK_AFTER:
                self.off_clock.add(source)

    def _admit_unlisted(self, vehicle_id: str) -> bool:
        """With ``accept_unlisted``: True for a vehicle already admitted, or a new one while there is room."""
        if not self.accept_unlisted:
            return False
        if vehicle_id in self.unlisted:
            return True
        if len(self.unlisted) >= MAX_UNLISTED:
            return False
        self.unlisted.append(vehicle_id)
        log.warning("accepting reports from %r, which is not in the roster (accept_unlisted)", vehicle_id)
        return True


def _implausible(message: SensorReport | NavReport | TargetTruth) -> str | None:
    """What makes a valid message absurd for a ground station (positions beyond :data:`MAX_ABS_POSITION_M`
    of the origin, ranges beyond :data:`MAX_RANGE_M`), or None."""
    if isinstance(message, SensorReport):
        x, y, z = message.vehicle_position_enu_m
        if not (abs(x) <= MAX_ABS_POSITION_M and abs(y) <= MAX_ABS_POSITION_M and abs(z) <= MAX_ABS_ALTITUDE_M):
            return f"vehicle position {message.vehicle_position_enu_m} m is beyond {MAX_ABS_POSITION_M:g} m"
        for k, detection in enumerate(message.detections):
            if detection.range_m is not None and detection.range_m > MAX_RANGE_M:
                return f"detections[{k}]: range {detection.range_m} m is beyond {MAX_RANGE_M:g} m"
    elif isinstance(message, TargetTruth):
        if not all(abs(v) <= MAX_ABS_POSITION_M for v in message.position_enu_m):
            return f"target position {message.position_enu_m} m is beyond {MAX_ABS_POSITION_M:g} m"
    return None


class _Recent:
    """The stamps accepted from one source within :data:`REORDER_WINDOW_NS` of its newest (for duplicates),
    at most :data:`MAX_RECENT` of them: a stamp at or below one forgotten cannot be checked, so it is stale."""

    __slots__ = ("newest", "forgotten", "_stamps", "_heap")

    def __init__(self) -> None:
        self.newest: int | None = None
        self.forgotten: int | None = None
        self._stamps: set[int] = set()
        self._heap: list[int] = []

    def check(self, stamp: int) -> str | None:
        """None if ``stamp`` may be accepted, else the rejection reason."""
        if stamp in self._stamps:
            return "duplicate"
        if self.newest is not None and stamp < self.newest - REORDER_WINDOW_NS:
            return "stale"
        if self.forgotten is not None and stamp <= self.forgotten:
            return "stale"
        return None

    def add(self, stamp: int) -> None:
        """Remember an accepted stamp; forget those that fell out of the window (or beyond the bound)."""
        self._stamps.add(stamp)
        heapq.heappush(self._heap, stamp)
        self.newest = stamp if self.newest is None else max(self.newest, stamp)
        floor = self.newest - REORDER_WINDOW_NS
        while self._heap and (self._heap[0] < floor or len(self._heap) > MAX_RECENT):
            oldest = heapq.heappop(self._heap)
            self._stamps.discard(oldest)
            if oldest >= floor:  # forgotten for room, not age: what is not after it can no longer be checked
                self.forgotten = oldest if self.forgotten is None else max(self.forgotten, oldest)
