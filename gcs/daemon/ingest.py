"""Validation of everything the daemon receives over Zenoh: accept, or reject with a counted reason.

Every sample goes through :meth:`Ingest.accept`, which returns the decoded
message or ``None``. Rejections are counted under ``rejected.<reason>`` and
logged (the first few of each reason at WARNING, the rest at DEBUG, so a
flood of bad input cannot flood the log); nothing raises. Reasons:

* the codec's (:data:`protocols.REJECT_REASONS`): ``key``, ``encoding``,
  ``unexpected_type``, ``malformed``, ``invalid``, ``oversize``;
* ``id_mismatch``: the message's ``vehicle_id`` differs from its key's;
* ``unknown_vehicle``: not in the scenario's roster;
* ``out_of_order``: a stamp not newer than the last accepted one of the same
  kind from the same vehicle (duplicates included);
* ``future``: a stamp more than :data:`MAX_AHEAD_NS` after the newest accepted
  one from anybody (a clock gone wrong must not make that vehicle's later
  reports look old, nor hold the decision steps back);
* ``unexpected_kind``: a key of the key space the daemon does not consume.

Accepted messages are counted under ``accepted.<kind>``.
"""

from __future__ import annotations

import logging
from collections import Counter

from gcs.adapters.zenoh_io import Received
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.keys import MESSAGE_TYPE_BY_KIND, ParsedKey, parse_key
from protocols.messages import NavReport, SensorReport, TargetTruth

__all__ = ["Ingest", "WARN_FIRST"]

log = logging.getLogger(__name__)

WARN_FIRST = 5
"""Rejections of each reason logged at WARNING before the rest go to DEBUG."""

_CONSUMED = {"report", "nav", "truth"}
MAX_AHEAD_NS = 60 * 1_000_000_000
"""How far a stamp may run ahead of the newest accepted one (a minute of data time)."""
MAX_CACHED_KEYS = 4096
"""Parsed keys remembered (a few per vehicle); a flood of made-up keys cannot grow the cache beyond this."""


class Ingest:
    """Decode and validate samples for a roster of vehicles under a key prefix."""

    def __init__(self, roster: set[str], prefix: str = "gcs") -> None:
        self.roster = set(roster)
        self.prefix = prefix
        self.counters: Counter = Counter()
        self._last_stamp: dict[tuple[str, str], int] = {}
        self._keys: dict[str, ParsedKey] = {}
        self._newest_ns: int | None = None

    def reject(self, reason: str, detail: str) -> None:
        """Count and log one rejection."""
        name = f"rejected.{reason}"
        self.counters[name] += 1
        level = logging.WARNING if self.counters[name] <= WARN_FIRST else logging.DEBUG
        log.log(level, "rejected (%s): %s", reason, detail)

    def accept(self, received: Received) -> SensorReport | NavReport | TargetTruth | None:
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
        if parsed.kind not in _CONSUMED:
            self.reject("unexpected_kind", f"{received.key}: the daemon does not consume {parsed.kind!r} keys")
            return None
        try:
            message = decode(received.payload, received.encoding, MESSAGE_TYPE_BY_KIND[parsed.kind])
        except ProtocolError as error:
            self.reject(error.reason, f"{received.key}: {error}")
            return None
        if parsed.kind == "truth":
            source = message.target_id
        else:
            source = message.vehicle_id
            if source != parsed.ident:
                self.reject("id_mismatch", f"{received.key}: message says vehicle_id={source!r}")
                return None
            if source not in self.roster:
                self.reject("unknown_vehicle", f"{received.key}: {source!r} is not in the roster")
                return None
        last = self._last_stamp.get((parsed.kind, source))
        if last is not None and message.stamp_ns <= last:
            self.reject("out_of_order", f"{received.key}: stamp {message.stamp_ns} not after {last}")
            return None
        if self._newest_ns is not None and message.stamp_ns > self._newest_ns + MAX_AHEAD_NS:
            self.reject("future", f"{received.key}: stamp {message.stamp_ns} is more than "
                                  f"{MAX_AHEAD_NS // 1_000_000_000} s after the newest ({self._newest_ns})")
            return None
        self._last_stamp[(parsed.kind, source)] = message.stamp_ns
        self._newest_ns = message.stamp_ns if self._newest_ns is None else max(self._newest_ns, message.stamp_ns)
        self.counters[f"accepted.{parsed.kind}"] += 1
        return message
