"""Free loopback ports, for the demo and for tests: every socket is on 127.0.0.1."""

from __future__ import annotations

import socket

__all__ = ["LOCALHOST", "free_port", "free_udp_port", "free_tcp_port"]

LOCALHOST = "127.0.0.1"


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port on 127.0.0.1 that is free now (UDP by default; ``socket.SOCK_STREAM`` for TCP)."""
    with socket.socket(socket.AF_INET, kind) as probe:
        probe.bind((LOCALHOST, 0))
        return probe.getsockname()[1]


def free_udp_port() -> int:
    """A free UDP port on 127.0.0.1."""
    return free_port(socket.SOCK_DGRAM)


def free_tcp_port() -> int:
    """A free TCP port on 127.0.0.1 (e.g. for a zenoh ``tcp/127.0.0.1:<port>`` endpoint)."""
    return free_port(socket.SOCK_STREAM)
