"""Loopback helpers shared by integration and end-to-end tests: every socket is on 127.0.0.1.

No port is guessed. Whoever listens binds port 0 and the test reads back the
port the system chose: a daemon's (:func:`daemon_ports`), a ``gcs run`` or
``gcs router`` process's from the line it prints (:class:`Lines`), a socket's
from ``getsockname``. Where a test needs a port nobody answers on, it holds one
bound without listening (:func:`silent_port`).
"""

from __future__ import annotations

import queue
import re
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO

from gcs.adapters.loopback import LOCALHOST

__all__ = ["LOCALHOST", "ANY_PORT_ENDPOINT", "ANY_UDP", "silent_port", "daemon_ports", "Lines", "daemon_up",
           "DAEMON_UP"]

ANY_PORT_ENDPOINT = f"tcp/{LOCALHOST}:0"
"""A zenoh endpoint to listen on at a port the system chooses."""
ANY_UDP = f"udpin:{LOCALHOST}:0"
"""A MAVLink connection to listen on at a port the system chooses (the vehicles given it share the port)."""


@contextmanager
def silent_port(kind: int = socket.SOCK_STREAM) -> Iterator[int]:
    """A port held bound (never listened on or read) for the block: a TCP connection to it is refused, a UDP
    datagram to it is never answered, and no other program can take it meanwhile."""
    with socket.socket(socket.AF_INET, kind) as held:
        held.bind((LOCALHOST, 0))
        yield held.getsockname()[1]


def daemon_ports(daemon) -> tuple[str, dict[str, int]]:
    """An opened daemon's zenoh endpoint (its first listening one; "" for a client) and each vehicle's MAVLink
    port, as the system bound them."""
    endpoint = daemon.zenoh_listening[0] if daemon.zenoh_listening else ""
    return endpoint, {vehicle: int(bound.rsplit(":", 1)[1]) for vehicle, bound in daemon.mavlink_bound.items()}


class Lines:
    """The lines a process writes to one of its pipes, read on a thread, waited for by pattern."""

    def __init__(self, stream: IO[str]) -> None:
        self.seen: list[str] = []
        self._queue: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self._queue.put(line)
        self._queue.put(None)

    def wait_for(self, pattern: str, timeout_s: float = 60.0) -> re.Match:
        """The first line (from here on) matching ``pattern``; AssertionError naming what was seen when the
        stream ends or ``timeout_s`` passes first."""
        regex = re.compile(pattern)
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                line = self._queue.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError(f"no line matching {pattern!r} within {timeout_s} s: {self.seen[-20:]}") from None
            if line is None:
                raise AssertionError(f"the stream ended before a line matching {pattern!r}: {self.seen[-20:]}")
            self.seen.append(line)
            match = regex.search(line)
            if match:
                return match

    def rest(self, timeout_s: float = 30.0) -> str:
        """Everything read, once the stream has ended (the process exited) or ``timeout_s`` passed."""
        self._thread.join(timeout_s)
        while not self._queue.empty():
            line = self._queue.get_nowait()
            if line is not None:
                self.seen.append(line)
        return "".join(self.seen)


DAEMON_UP = r"daemon up: .*zenoh \w+ listen (\[[^\]]*\]).*MAVLink (.*)$"
"""The line ``gcs run`` logs once open: its zenoh listening endpoints and each vehicle's MAVLink connection."""


def daemon_up(lines: Lines, timeout_s: float = 60.0) -> tuple[str, dict[str, int]]:
    """Wait for a ``gcs run`` process's ``daemon up`` line; its zenoh endpoint and each vehicle's MAVLink port
    (for ``udpin`` connections)."""
    match = lines.wait_for(DAEMON_UP, timeout_s)
    endpoints = re.findall(r"'([^']+)'", match.group(1))
    ports = {vehicle: int(port) for vehicle, port in re.findall(r"(\w+) udpin:[\d.]+:(\d+)", match.group(2))}
    return (endpoints[0] if endpoints else ""), ports
