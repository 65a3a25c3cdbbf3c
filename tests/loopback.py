"""Loopback helpers shared by integration and end-to-end tests: every socket is on 127.0.0.1."""

from gcs.adapters.ports import LOCALHOST, free_port, free_tcp_port, free_udp_port

__all__ = ["LOCALHOST", "free_port", "free_tcp_port", "free_udp_port"]
