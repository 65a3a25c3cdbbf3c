"""Loopback, the one address every socket of the tests and the demo is on.

Ports are never guessed: a listener binds port 0 and reads back the port the
system chose (:func:`gcs.adapters.zenoh_session.listening_endpoints`,
:meth:`gcs.adapters.mavlink_io.MavlinkCommander.bound_connections`, a
socket's ``getsockname``).
"""

from __future__ import annotations

__all__ = ["LOCALHOST"]

LOCALHOST = "127.0.0.1"
