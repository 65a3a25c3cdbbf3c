"""The live map of a daemon or a replay: a :class:`~gcs.daemon.picture.Picture` and its HTTP server.

The producer's loop calls :meth:`LiveMap.observe` (decoded messages) or
:meth:`LiveMap.observe_wire` (payload bytes) as data passes, and
:meth:`LiveMap.publish` every turn; a snapshot is built and handed to the
server at most :data:`PUBLISH_RATE_HZ` times a second of wall time, so the
page costs the loop a few hundred microseconds five times a second and
nothing else (the server runs on its own threads).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from gcs.adapters.web.server import LiveMapServer
from gcs.config import Scenario
from gcs.core.world import World
from gcs.daemon.picture import Picture, encode_json
from protocols.messages import DaemonStatus, Message

__all__ = ["LiveMap", "PUBLISH_RATE_HZ"]

log = logging.getLogger(__name__)

PUBLISH_RATE_HZ = 5.0
"""Snapshots per second of wall time, at most."""


class LiveMap:
    """See the module docstring; build with :meth:`open`, finish with :meth:`close`."""

    def __init__(self, picture: Picture, server: LiveMapServer, rate_hz: float = PUBLISH_RATE_HZ) -> None:
        self.picture, self.server = picture, server
        self.period_s = 1.0 / rate_hz
        self._next_s: float | None = None
        self.snapshots = 0
        self.failures = 0

    @classmethod
    def open(cls, address: tuple[str, int], scenario: Scenario, world: World, mode: str = "live",
             control: Callable[[dict], dict] | None = None, rate_hz: float = PUBLISH_RATE_HZ) -> LiveMap:
        """Bind ``address`` and start serving (OSError when it cannot be bound)."""
        picture = Picture(scenario, world, mode=mode)
        return cls(picture, LiveMapServer(address, encode_json(picture.world), control), rate_hz)

    @property
    def url(self) -> str:
        """``http://host:port/`` where the page is."""
        return self.server.url

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

    def publish(self, now_s: float, status: Callable[[], DaemonStatus | None] | None = None,
                extra: dict | None = None, force: bool = False) -> bool:
        """Build and serve a snapshot if one is due at wall time ``now_s`` (or ``force``); True if it was."""
        if not force and self._next_s is not None and now_s < self._next_s:
            return False
        self._next_s = now_s + self.period_s
        try:
            tracks, summary = self.picture.snapshot(status() if status is not None else None, extra)
            summary["counters"].update(self.server.counters)
            self.server.publish(encode_json(tracks), encode_json(summary))
        except Exception:
            self._failed("a snapshot")
            return False
        self.snapshots += 1
        return True

    def close(self) -> None:
        """Stop the server (idempotent)."""
        self.server.close()
