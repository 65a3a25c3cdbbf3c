"""The live map of a daemon or a replay: a :class:`~gcs.adapters.live_map.picture.Picture`, its HTTP server and,
optionally, Foxglove outputs (:mod:`gcs.adapters.foxglove_out`).

The producer's loop calls :meth:`LiveMap.observe` (decoded messages) or
:meth:`LiveMap.observe_wire` (payload bytes) as data passes, a federation member's daemon
:meth:`LiveMap.observe_federation` with each :class:`~gcs.engine.federation.PublishMemberTracks`, and
:meth:`LiveMap.publish` every turn; a snapshot is built and handed to the
server at most :data:`PUBLISH_RATE_HZ` times a second of wall time, so the
page costs the loop a few hundred microseconds five times a second and
nothing else (the server runs on its own threads).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping

from gcs.adapters.foxglove_out import FoxgloveOptions, FoxgloveOut
from gcs.adapters.web.server import LiveMapServer
from gcs.config import Scenario
from gcs.core.world import World
from gcs.engine.federation import PublishMemberTracks
from gcs.adapters.live_map.picture import Picture
from gcs.adapters.live_map.picture_geometry import encode_json
from protocols.federation import MemberTracks
from protocols.messages import DaemonStatus, Message

__all__ = ["LiveMap", "PUBLISH_RATE_HZ"]

log = logging.getLogger(__name__)

PUBLISH_RATE_HZ = 5.0
"""Snapshots per second of wall time, at most."""


class LiveMap:
    """See the module docstring; build with :meth:`open`, finish with :meth:`close`."""

    def __init__(self, picture: Picture, server: LiveMapServer | None, rate_hz: float = PUBLISH_RATE_HZ,
                 foxglove: FoxgloveOut | None = None) -> None:
        self.picture, self.server, self.foxglove = picture, server, foxglove
        self.period_s = 1.0 / rate_hz
        self._next_s: float | None = None
        self.snapshots = 0
        self.failures = 0

    @classmethod
    def open(cls, address: tuple[str, int] | None, scenario: Scenario, world: World, mode: str = "live",
             control: Callable[[dict], dict] | None = None, rate_hz: float = PUBLISH_RATE_HZ,
             foxglove: FoxgloveOptions | None = None) -> LiveMap:
        """Bind ``address`` and start serving (None: no page), and open the Foxglove outputs if asked.

        Raises OSError when the address cannot be bound, :class:`FoxgloveMissing` without the
        foxglove extra, RuntimeError when Foxglove's server or file cannot be opened.
        """
        picture = Picture(scenario, world, mode=mode)
        server = None if address is None else LiveMapServer(address, encode_json(picture.world), control)
        out = None
        try:
            if foxglove is not None:
                out = FoxgloveOut(picture.frame, picture.world, foxglove)
        except BaseException:
            if server is not None:
                server.close()
            raise
        return cls(picture, server, rate_hz, out)

    @property
    def url(self) -> str | None:
        """``http://host:port/`` where the page is (None without a page)."""
        return None if self.server is None else self.server.url

    def _failed(self, what: str) -> None:
        """A bug in the picture must not take the producer down: logged (with the trace once) and counted."""
        self.failures += 1
        if self.failures == 1:
            log.exception("live map: %s failed; the map may be stale (counted in errors.live_map)", what)
        else:
            log.debug("live map: %s failed again", what, exc_info=True)
        self.picture.counters["errors.live_map"] = self.failures

    def observe(self, message: Message | None) -> None:
        """A decoded message the producer received or published (None is ignored)."""
        if message is not None:
            try:
                self.picture.observe(message)
            except Exception:
                self._failed(f"observing a {type(message).__name__}")

    def observe_wire(self, payload: bytes, encoding: str) -> None:
        """A message as bytes with its Zenoh encoding."""
        try:
            self.picture.observe_wire(payload, encoding)
        except Exception:
            self._failed(f"observing a {encoding}")

    def observe_federation(self, published: PublishMemberTracks, members: Mapping[str, MemberTracks]) -> None:
        """The engine's federation action of a decision step and the other members' newest messages
        (``engine.federation.picture.members``): the map draws every member's area and the federation's targets."""
        try:
            self.picture.observe_federation(published, members)
        except Exception:
            self._failed("observing the federation")

    def publish(self, now_s: float, status: Callable[[], DaemonStatus | None] | None = None,
                extra: dict | None = None, force: bool = False, log_time_ns: int | None = None) -> bool:
        """Build and serve a snapshot if one is due at wall time ``now_s`` (or ``force``); True if it was.

        ``log_time_ns`` is the Foxglove log time (default: the wall clock now)."""
        if not force and self._next_s is not None and now_s < self._next_s:
            return False
        self._next_s = now_s + self.period_s
        try:
            tracks, summary = self.picture.snapshot(status() if status is not None else None, extra)
            if self.server is not None:
                summary["counters"].update(self.server.counters)
                self.server.publish(encode_json(tracks), encode_json(summary))
            if self.foxglove is not None:
                self.foxglove.log(tracks, summary, time.time_ns() if log_time_ns is None else log_time_ns)
        except Exception:
            self._failed("a snapshot")
            return False
        self.snapshots += 1
        return True

    def close(self) -> None:
        """Stop the server and finish the Foxglove outputs (idempotent)."""
        try:
            if self.server is not None:
                self.server.close()
        finally:
            if self.foxglove is not None:
                self.foxglove.close()
