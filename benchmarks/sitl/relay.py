"""A TCP relay between the daemon and an autopilot's port, which can cut the link for a while: a radio link lost and
found again.

The relay listens on a loopback port (``0``: the system chooses; :attr:`TcpRelay.port` says which) and
joins each client it accepts to a new connection to the autopilot, copying bytes both ways in a thread
of its own. :meth:`TcpRelay.cut` closes both sides at once and stops listening (a client is refused) until
:meth:`TcpRelay.restore` listens on the same port again; the client (the daemon's :class:`~gcs.adapters.mavlink_tcp.RetryingTcp`) then
finds the link gone and connects again once it is back.
"""

from __future__ import annotations

import selectors
import socket
import threading

__all__ = ["TcpRelay"]


class TcpRelay:
    """Relays ``127.0.0.1:port`` to ``upstream`` (module docstring); :meth:`close` ends it."""

    def __init__(self, upstream: tuple[str, int]) -> None:
        self.upstream = upstream
        self.listener: socket.socket | None = self._listen(0)
        self.port = int(self.listener.getsockname()[1])
        self.cuts = 0
        self._pairs: list[tuple[socket.socket, socket.socket]] = []
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name=f"relay-{self.port}", daemon=True)
        self._thread.start()

    @staticmethod
    def _listen(port: int) -> socket.socket:
        listener = socket.create_server(("127.0.0.1", port))  # SO_REUSEADDR: the same port again after a cut
        listener.setblocking(False)
        return listener

    def cut(self) -> None:
        """Close the relayed connections and stop listening."""
        with self._lock:
            if self.listener is not None:
                self.listener.close()
                self.listener = None
            for pair in self._pairs:
                for sock in pair:
                    sock.close()
            self._pairs.clear()
        self.cuts += 1

    def restore(self) -> None:
        """Listen on the same port and relay again."""
        with self._lock:
            if self.listener is None:
                self.listener = self._listen(self.port)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.cut()

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                pairs, listener = list(self._pairs), self.listener
            selector = selectors.DefaultSelector()
            if listener is not None:
                selector.register(listener, selectors.EVENT_READ, listener)
            for pair in pairs:
                for end, other in (pair, pair[::-1]):
                    if end.fileno() >= 0:
                        selector.register(end, selectors.EVENT_READ, (end, other, pair))
            for key, _ in selector.select(timeout=0.05):
                if isinstance(key.data, socket.socket):
                    self._accept(key.data)
                else:
                    self._copy(*key.data)
            selector.close()

    def _accept(self, listener: socket.socket) -> None:
        try:
            client, _ = listener.accept()
        except OSError:  # nobody after all, or cut meanwhile
            return
        try:
            autopilot = socket.create_connection(self.upstream, timeout=2.0)
        except OSError:
            client.close()
            return
        with self._lock:
            self._pairs.append((client, autopilot))

    def _copy(self, source: socket.socket, sink: socket.socket, pair: tuple[socket.socket, socket.socket]) -> None:
        try:
            data = source.recv(65536)
            if data:
                sink.sendall(data)
                return
        except OSError:
            pass
        with self._lock:  # one side closed: close both
            if pair in self._pairs:
                self._pairs.remove(pair)
        for sock in pair:
            sock.close()
