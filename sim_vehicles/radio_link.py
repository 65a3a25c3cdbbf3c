"""A radio link between simulated vehicles and a ground station that can go out of range: a UDP relay on 127.0.0.1.

:class:`UdpRelay` forwards UDP datagrams between one vehicle side and a ground station;
``muted`` drops everything both ways, like a radio out of range, while Zenoh goes on
(``gcs-bench soak`` mutes and unmutes links at random; the daemon's tests of MAVLink
silence mute one). Both of its ports are the ones the system chose: the vehicles send
to :attr:`UdpRelay.port`, the ground station to :attr:`UdpRelay.ground_port`
(``udpout``), and each side's address is learnt from its datagrams.
"""

from __future__ import annotations

import socket
import threading

from gcs.adapters.loopback import LOCALHOST

__all__ = ["UdpRelay"]


class UdpRelay:
    """A UDP relay between vehicles (they send to :attr:`port`) and a ground station that sends to
    :attr:`ground_port` (its MAVLink ``udpout:127.0.0.1:<ground_port>``); either side is heard before it is
    sent to, as a radio link would (until then its datagrams for the other side are dropped)."""

    def __init__(self) -> None:
        self.outer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the vehicles send here
        self.outer.bind((LOCALHOST, 0))
        self.inner = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # and the ground station here
        self.inner.bind((LOCALHOST, 0))
        for sock in (self.outer, self.inner):
            sock.settimeout(0.05)
        self.port = self.outer.getsockname()[1]
        self.ground_port = self.inner.getsockname()[1]
        self.vehicles: tuple[str, int] | None = None
        self.ground: tuple[str, int] | None = None
        self.muted = False
        self.dropped = 0
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._pump, args=(self.outer, True), daemon=True, name="relay-out"),
                         threading.Thread(target=self._pump, args=(self.inner, False), daemon=True, name="relay-in")]
        for thread in self._threads:
            thread.start()

    def _pump(self, sock: socket.socket, from_vehicles: bool) -> None:
        while not self._stop.is_set():
            try:
                data, address = sock.recvfrom(65536)
            except (TimeoutError, socket.timeout):
                continue
            except OSError:
                return
            if from_vehicles:
                self.vehicles = address  # a restarted vehicle process sends from a new port
            else:
                self.ground = address
            if self.muted:
                self.dropped += 1
                continue
            other = self.ground if from_vehicles else self.vehicles
            if other is None:
                continue  # the other side has not been heard yet: nowhere to send
            try:
                if from_vehicles:
                    self.inner.sendto(data, other)
                else:
                    self.outer.sendto(data, other)
            except OSError:  # nobody listening (yet): like a radio link, the datagram is gone
                pass

    def close(self) -> None:
        """Stop forwarding and close both sockets."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5)
        self.outer.close()
        self.inner.close()
