"""A MAVLink TCP client that waits for its peer: connects in the background, and again after the peer goes.

An autopilot's TCP port (ArduPilot SITL's SERIAL0 and SERIAL1, a telemetry
radio's network bridge) may not be listening yet when the ground station
starts, and it goes away when the autopilot reboots or the network drops.
pymavlink's own ``tcp:`` client tries a few times, sleeping a second between
tries, then raises; and once connected it sleeps inside ``recv`` to reconnect,
which would stall the daemon's loop. :class:`RetryingTcp` is a pymavlink
``mavfile`` whose socket connects without blocking: ``recv`` and ``write`` try a
connection at most every ``retry_s`` while there is none (reading nothing and
dropping what is written meanwhile), and a peer that closes or resets the
connection is reconnected the same way. Each outage is logged once when it
begins and once when the link is back.
"""

from __future__ import annotations

import errno
import logging
import select
import socket
import time
from collections.abc import Callable

from gcs.adapters.mavlink_v2 import mavutil

__all__ = ["RetryingTcp", "RETRY_S"]

log = logging.getLogger(__name__)

RETRY_S = 1.0
"""Seconds between connection attempts while the peer does not answer."""
CONNECT_TIMEOUT_S = 5.0
"""A connection attempt that has neither succeeded nor failed after this long is abandoned and tried again."""
CLOSE_WAIT_S = 0.5
"""How long closing waits for the peer to take what was written and close its side."""
_GONE = (errno.ECONNRESET, errno.EPIPE, errno.ECONNABORTED, errno.ENOTCONN, errno.ETIMEDOUT, errno.EHOSTUNREACH)


class RetryingTcp(mavutil.mavfile):
    """``tcp:HOST:PORT`` as a pymavlink connection that keeps trying (module docstring).

    ``connected`` says whether a connection is up; ``connects`` counts the connections made and
    ``dropped_writes`` the messages written while there was none.
    """

    def __init__(self, address: str, source_system: int = 255, source_component: int = 0,
                 retry_s: float = RETRY_S, clock: Callable[[], float] = time.monotonic) -> None:
        host, _, port = address.rpartition(":")
        self.destination_addr = (host, int(port))
        self.retry_s, self.clock = retry_s, clock
        self.port: socket.socket | None = None
        self.connected = False
        self.connects = 0
        self.dropped_writes = 0
        self._attempt_s: float | None = None
        self._waiting_logged = False
        mavutil.mavfile.__init__(self, None, "tcp:" + address, source_system=source_system,
                                 source_component=source_component)
        self._connect()

    # ------------------------------------------------------------ connection

    def _connect(self) -> None:
        """Start an attempt when none is under way and the last began ``retry_s`` ago; finish one that has."""
        now = self.clock()
        if self.port is not None:
            self._finish_attempt(now)
            return
        if self._attempt_s is not None and now - self._attempt_s < self.retry_s:
            return
        self._attempt_s = now
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setblocking(False)
        code = sock.connect_ex(self.destination_addr)
        if code not in (0, errno.EINPROGRESS, errno.EAGAIN):
            sock.close()
            self._not_answering(errno.errorcode.get(code, str(code)))
            return
        self.port = sock
        self._finish_attempt(now)

    def _finish_attempt(self, now: float) -> None:
        """Check an attempt under way: up, refused (closed, retried later) or still pending."""
        assert self.port is not None
        if self.connected:
            return
        _, writable, _ = select.select([], [self.port], [], 0)
        if not writable:
            if self._attempt_s is not None and now - self._attempt_s > CONNECT_TIMEOUT_S:
                self._drop("no answer within %g s" % CONNECT_TIMEOUT_S)
            return
        code = self.port.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        if code != 0:
            self._drop(errno.errorcode.get(code, str(code)))
            return
        self.port.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.connected, self.fd = True, self.port.fileno()
        self.connects += 1
        self._waiting_logged = False
        log.info("MAVLink %s: connected", self.address)

    def _not_answering(self, reason: str) -> None:
        if not self._waiting_logged:
            self._waiting_logged = True
            log.warning("MAVLink %s: no answer yet (%s); retrying every %g s", self.address, reason, self.retry_s)

    def _drop(self, reason: str) -> None:
        """Close the socket; the next call tries again after ``retry_s``."""
        was_connected = self.connected
        if self.port is not None:
            self.port.close()
        self.port, self.connected, self.fd = None, False, None  # type: ignore[assignment]  # mavfile's fd: None
        if was_connected:
            self._waiting_logged = True
            log.warning("MAVLink %s: connection lost (%s); reconnecting every %g s", self.address, reason,
                        self.retry_s)
        else:
            self._not_answering(reason)

    # ------------------------------------------------------------ mavfile

    def recv(self, n: int | None = None) -> bytes:
        if not self.connected:
            self._connect()
            if not self.connected:
                return b""
        assert self.port is not None
        try:
            data = self.port.recv(n if n is not None else self.mav.bytes_needed())
        except BlockingIOError:
            return b""
        except OSError as error:
            if error.errno in _GONE:
                self._drop(errno.errorcode.get(error.errno or 0, str(error)))
                return b""
            raise
        if not data:
            self._drop("closed by the peer")
        return data

    def write(self, buf: bytes) -> None:
        if not self.connected:
            self._connect()
            if not self.connected:
                self.dropped_writes += 1
                return
        assert self.port is not None
        try:
            self.port.sendall(buf)
        except BlockingIOError:
            self.dropped_writes += 1
        except OSError as error:
            if error.errno not in _GONE:
                raise
            self.dropped_writes += 1
            self._drop(errno.errorcode.get(error.errno or 0, str(error)))

    def close(self) -> None:
        """Close gracefully: what was written goes out before the connection ends (a socket closed with unread
        input is reset at once, and its unsent output lost: the hand-back of a daemon that stops among it)."""
        if self.port is not None:
            if self.connected:
                self._drain_and_finish()
            self.port.close()
        self.port, self.connected, self.fd = None, False, None  # type: ignore[assignment]

    def _drain_and_finish(self) -> None:
        """Send FIN after the pending output, and read what the peer still sends until it closes too (at most
        :data:`CLOSE_WAIT_S`)."""
        assert self.port is not None
        try:
            self.port.shutdown(socket.SHUT_WR)
            deadline = self.clock() + CLOSE_WAIT_S
            while (left := deadline - self.clock()) > 0:
                readable, _, _ = select.select([self.port], [], [], left)
                if readable and not self.port.recv(65536):
                    return
        except OSError:
            return
