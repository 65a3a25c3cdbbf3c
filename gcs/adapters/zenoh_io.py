"""The daemon's Zenoh side: subscriptions that only enqueue, publications, queryables.

Every subscription (reports, nav, truth, the vehicles' scenarios, liveliness) delivers into a Zenoh
FIFO channel (:data:`INBOX_CAPACITY` samples each): Zenoh's threads only
enqueue, and never run Python, so they never take the interpreter from the
loop (a Python callback per sample did, thousands of times a second). A full
channel makes Zenoh wait, which the reliable publishers pass back to the
senders: nothing is dropped. The daemon's loop drains the channels, stamps the
receive time, decodes and validates. Queries (``gcs/track/*``,
``gcs/daemon/status``) are taken from the queryables' channels by the loop too,
and answered from the latest published payloads.

A member of a federation of daemons (``federation=(prefix, member_id)``) also subscribes to every
member's tracks (``<federation>/federation/*/tracks``) and liveliness (``.../*/alive``, with the
tokens already declared), delivered like the rest; holds its own liveliness token on
``<federation>/federation/<member>/alive`` while the session is open; publishes its
:class:`~protocols.federation.MemberTracks` on ``<federation>/federation/<member>/tracks``, and
answers queries there with the latest (``gcs status --federation``). Its own messages do not come back
through its subscription (it takes only other sessions' samples), so a recording holds each once.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import zenoh

from gcs.adapters.zenoh_session import ZenohSettings, declare_publisher, open_session
from protocols.codec import encode
from protocols.keys import (alive_selector, member_alive_key, member_alive_selector, member_tracks_key,
                            member_tracks_selector, navs_selector, plan_key, reports_selector, scenarios_selector,
                            status_key, track_key, tracks_selector, truth_selector)
from protocols.messages import DaemonStatus, MemberTracks, Message, PlanCommand, TrackEstimate

__all__ = ["Received", "ZenohIO", "INBOX_CAPACITY"]

log = logging.getLogger(__name__)

INBOX_CAPACITY = 65_536
"""Samples each subscription holds before Zenoh waits for the loop (about 13 s of 5,000 reports/s)."""
POLL_S = 0.0005
"""How often an idle loop looks for input."""


@dataclass(frozen=True)
class Received:
    """One sample as it arrived: key, exact payload bytes, encoding, receive time (ns, wall clock)."""

    kind: Literal["sample", "alive", "gone"]
    key: str
    payload: bytes
    encoding: str
    received_ns: int


class ZenohIO:
    """Subscriptions to reports, nav, truth, scenarios and liveliness; publications of tracks, plans and status
    (and a federation member's, module docstring)."""

    def __init__(self, settings: ZenohSettings, prefix: str = "gcs",
                 clock_ns: Callable[[], int] = time.time_ns,
                 tap: Callable[[str, bytes, str, int], None] | None = None,
                 federation: tuple[str, str] | None = None) -> None:
        """``tap(key, payload, encoding, time_ns)`` sees every message this side publishes (for recording);
        ``federation``: the federation's prefix and this member's id, or None."""
        self.settings, self.prefix, self.clock_ns, self.tap = settings, prefix, clock_ns, tap
        self.federation = federation
        self._member_key = None if federation is None else member_tracks_key(federation[1], federation[0])
        self.session: zenoh.Session | None = None
        self._entities: list = []
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._latest: dict[str, tuple[bytes, str]] = {}
        self._samples: list = []
        self._liveliness: zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]] | None = None
        self._member_liveliness: zenoh.Subscriber[zenoh.handlers.Handler[zenoh.Sample]] | None = None
        self._member_queries: zenoh.Queryable | None = None
        self._held: list[Received] = []

    def open(self) -> zenoh.Session:
        """Open the session and declare every subscriber and queryable; the session."""
        session = self.session = open_session(self.settings)
        for selector in (reports_selector(self.prefix), navs_selector(self.prefix), truth_selector(self.prefix),
                         scenarios_selector(self.prefix)):
            self._samples.append(self.session.declare_subscriber(selector, zenoh.handlers.FifoChannel(INBOX_CAPACITY)))
        self._liveliness = self.session.liveliness().declare_subscriber(
            alive_selector(self.prefix), zenoh.handlers.FifoChannel(INBOX_CAPACITY), history=True)
        self._tracks = self.session.declare_queryable(tracks_selector(self.prefix))
        self._status = self.session.declare_queryable(status_key(self.prefix))
        self._entities += [*self._samples, self._liveliness, self._tracks, self._status]
        if self.federation is not None:
            self._join_federation(session, *self.federation)
        return session

    def _join_federation(self, session: zenoh.Session, prefix: str, member_id: str) -> None:
        """Subscribe to the members' tracks and liveliness, declare this member's token and tracks' queryable."""
        tracks = session.declare_subscriber(member_tracks_selector(prefix), zenoh.handlers.FifoChannel(INBOX_CAPACITY),
                                            allowed_origin=zenoh.Locality.REMOTE)
        self._samples.insert(0, tracks)  # taken before the team's reports: a backlog is fused knowing the others
        self._member_liveliness = session.liveliness().declare_subscriber(
            member_alive_selector(prefix), zenoh.handlers.FifoChannel(INBOX_CAPACITY), history=True)
        self._member_queries = session.declare_queryable(member_tracks_key(member_id, prefix))
        token = session.liveliness().declare_token(member_alive_key(member_id, prefix))
        self._entities += [tracks, self._member_liveliness, self._member_queries, token]

    def wait(self, timeout_s: float, until: Callable[[], bool] | None = None) -> bool:
        """Wait until something is received, ``until()`` (if given) is true, or ``timeout_s`` passes
        (looking every :data:`POLL_S`); True if something was received. What came is kept for :meth:`drain`."""
        deadline = time.monotonic() + timeout_s
        while not self._held:
            self._held = self._take(100_000)
            if self._held or time.monotonic() >= deadline or (until is not None and until()):
                break
            time.sleep(POLL_S)
        return bool(self._held)

    def drain(self, limit: int = 100_000) -> list[Received]:
        """Everything received so far (up to ``limit``): liveliness first, then the samples (a federation's
        member tracks before the team's), each subscription's in the order received; stamped with the time they
        were taken."""
        out, self._held = self._held, []
        return out + self._take(limit - len(out))

    def _take(self, limit: int) -> list[Received]:
        out: list[Received] = []
        if self.session is None or self._liveliness is None:
            return out
        now = self.clock_ns()
        for liveliness in (self._liveliness, self._member_liveliness):
            while liveliness is not None and len(out) < limit and (sample := liveliness.try_recv()) is not None:
                out.append(Received("alive" if sample.kind == zenoh.SampleKind.PUT else "gone", str(sample.key_expr),
                                    b"", "", now))
        for subscriber in self._samples:
            while len(out) < limit and (sample := subscriber.try_recv()) is not None:
                out.append(Received("sample", str(sample.key_expr), sample.payload.to_bytes(), str(sample.encoding),
                                    now))
        return out

    def _put(self, key: str, message: Message) -> None:
        payload, encoding = encode(message)
        publisher = self._publishers.get(key)
        if publisher is None:
            if self.session is None:
                raise RuntimeError(f"cannot publish on {key}: the Zenoh session is not open (call open() first)")
            publisher = self._publishers[key] = declare_publisher(self.session, key, type(message))
        publisher.put(payload)  # the publisher was declared with this type's encoding
        self._latest[key] = (payload, encoding)
        if self.tap is not None:
            self.tap(key, payload, encoding, self.clock_ns())

    def publish_track(self, track: TrackEstimate) -> None:
        """Publish on ``<prefix>/track/<target>`` and keep it for queries."""
        self._put(track_key(track.target_id, self.prefix), track)

    def retire_track(self, target_id: str) -> None:
        """Stop publishing ``<prefix>/track/<target>`` and answering queries with it (the track was deleted)."""
        key = track_key(target_id, self.prefix)
        self._latest.pop(key, None)
        publisher = self._publishers.pop(key, None)
        if publisher is not None:
            try:
                publisher.undeclare()
            except zenoh.ZError as error:  # already gone with a broken session
                log.debug("undeclare failed: %s", error)

    def publish_plan(self, plan: PlanCommand) -> None:
        """Publish on ``<prefix>/plan/<vehicle>``."""
        self._put(plan_key(plan.vehicle_id, self.prefix), plan)

    def publish_member_tracks(self, message: MemberTracks) -> None:
        """Publish on ``<federation>/federation/<member>/tracks`` and keep it for queries."""
        if self._member_key is None:
            raise RuntimeError("cannot publish member tracks: this daemon is not a member of a federation")
        self._put(self._member_key, message)

    def publish_status(self, status: DaemonStatus) -> None:
        """Publish on ``<prefix>/daemon/status`` and keep it for queries."""
        self._put(status_key(self.prefix), status)

    def answer_queries(self, status: Callable[[], DaemonStatus] | None = None) -> int:
        """Reply to waiting queries; returns how many were answered.

        Track queries get the latest published tracks; status queries get
        ``status()`` (fresh) when given, else the latest published status.
        """
        answered = 0
        while (query := self._tracks.try_recv()) is not None:
            wanted = zenoh.KeyExpr(str(query.selector.key_expr))
            for key, (payload, encoding) in list(self._latest.items()):
                if key != status_key(self.prefix) and wanted.intersects(zenoh.KeyExpr(key)):
                    query.reply(key, payload, encoding=zenoh.Encoding(encoding))
            query.drop()
            answered += 1
        while (query := self._status.try_recv()) is not None:
            key = status_key(self.prefix)
            latest = encode(status()) if status is not None else self._latest.get(key)
            if latest is not None:
                query.reply(key, latest[0], encoding=zenoh.Encoding(latest[1]))
            query.drop()
            answered += 1
        while self._member_queries is not None and (query := self._member_queries.try_recv()) is not None:
            latest = self._latest.get(self._member_key or "")
            if latest is not None and self._member_key is not None:
                query.reply(self._member_key, latest[0], encoding=zenoh.Encoding(latest[1]))
            query.drop()
            answered += 1
        return answered

    def close(self) -> None:
        """Undeclare everything and close the session."""
        for entity in self._entities + list(self._publishers.values()):
            try:
                entity.undeclare()
            except zenoh.ZError as error:  # already gone with a broken session
                log.debug("undeclare failed: %s", error)
        self._entities.clear()
        self._samples, self._liveliness, self._member_liveliness, self._member_queries = [], None, None, None
        self._publishers.clear()
        if self.session is not None:
            self.session.close()
            self.session = None
