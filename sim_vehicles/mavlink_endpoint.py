"""MAVLink transport of the simulated vehicles: one socket per endpoint, shared by its vehicles.

All vehicles given the same connection string share one pymavlink connection,
like vehicles behind one radio hub: each sends with its own system id (its own
encoder, sequence numbers and signing state) and received messages are handed
to the vehicle their ``target_system`` names (``0``, or no target, goes to
every vehicle on the link). Sharing the socket avoids pymavlink's ``udpin``
pitfall (docs/mavlink.md): a GCS listening on one port answers the last
address it heard from, so vehicles on separate sockets would receive each
other's commands. Vehicles given their own connection string get their own link.

With a signing key, outgoing messages are signed and incoming unsigned or
wrongly signed ones are rejected by pymavlink (counted as ``bad_data``).
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field

from gcs.adapters.mavlink_wire import mavlink, open_connection, sign_outgoing

__all__ = ["MavlinkLink", "MavlinkEndpoints"]

log = logging.getLogger(__name__)

SIGNING_EPOCH_S = 1_420_070_400
"""MAVLink signing timestamps count 10 us units from 2015-01-01 00:00:00 UTC."""


@dataclass
class MavlinkLink:
    """One pymavlink connection and the vehicles (system ids) that use it."""

    connection: str
    sysids: list[int]
    signing_key: bytes | None = None
    counters: Counter = field(default_factory=Counter)

    def __post_init__(self) -> None:
        self.conn = open_connection(self.connection, source_system=self.sysids[0])
        self.encoders: dict[int, mavlink.MAVLink] = {}
        timestamp = int((max(time.time(), SIGNING_EPOCH_S) - SIGNING_EPOCH_S) * 100_000)
        for link_id, sysid in enumerate(self.sysids):
            encoder = mavlink.MAVLink(self.conn, srcSystem=sysid, srcComponent=1)
            if self.signing_key is not None:
                sign_outgoing(encoder, self.signing_key, link_id, timestamp)
            self.encoders[sysid] = encoder
        if self.signing_key is not None:
            self.conn.setup_signing(self.signing_key, sign_outgoing=False, allow_unsigned_callback=None)

    def send(self, sysid: int, message) -> None:
        """Send one message as vehicle ``sysid``."""
        try:
            self.encoders[sysid].send(message)
            self.counters["sent"] += 1
        except OSError as error:  # e.g. nobody listening on a udpout port yet: keep flying
            self.counters["send_errors"] += 1
            log.debug("MAVLink send on %s failed: %s", self.connection, error)

    def receive(self) -> Iterator[tuple[int | None, object]]:
        """Every message waiting on the socket, as (target sysid or None for all, message)."""
        while True:
            try:
                message = self.conn.recv_msg()
            except (OSError, ValueError) as error:
                self.counters["receive_errors"] += 1
                log.debug("MAVLink receive on %s failed: %s", self.connection, error)
                return
            if message is None:
                return
            if message.get_type() == "BAD_DATA":
                self.counters["bad_data"] += 1
                continue
            self.counters["received"] += 1
            target = getattr(message, "target_system", 0)
            if target == 0:
                yield None, message
            elif target in self.encoders:
                yield target, message
            else:
                self.counters["other_system"] += 1

    def close(self) -> None:
        """Close the socket."""
        self.conn.close()


class MavlinkEndpoints:
    """The links of all vehicles: ``{sysid: connection string}`` grouped by connection string."""

    def __init__(self, connections: dict[int, str], signing_key: bytes | None = None) -> None:
        groups: dict[str, list[int]] = {}
        for sysid, connection in connections.items():
            groups.setdefault(connection, []).append(sysid)
        self.links: list[MavlinkLink] = []
        try:
            for connection, sysids in groups.items():
                self.links.append(MavlinkLink(connection, sysids, signing_key))
        except Exception:
            self.close()
            raise
        self._link_of = {sysid: link for link in self.links for sysid in link.sysids}

    def encoder(self, sysid: int) -> mavlink.MAVLink:
        """The encoder of vehicle ``sysid`` (builds its messages; sending goes through :meth:`send`)."""
        return self._link_of[sysid].encoders[sysid]

    def send(self, sysid: int, message) -> None:
        """Send as vehicle ``sysid`` on its link."""
        self._link_of[sysid].send(sysid, message)

    def receive(self) -> Iterator[tuple[int, object]]:
        """Every waiting message, as (recipient sysid, message); broadcasts go to each vehicle of the link."""
        for link in self.links:
            for target, message in link.receive():
                for sysid in (link.sysids if target is None else (target,)):
                    yield sysid, message

    def counters(self) -> Counter:
        """Sum of every link's counters."""
        total: Counter = Counter()
        for link in self.links:
            total.update(link.counters)
        return total

    def close(self) -> None:
        """Close every link."""
        for link in self.links:
            link.close()
