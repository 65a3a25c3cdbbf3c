"""The TCP client that waits for its autopilot (:class:`gcs.adapters.mavlink_tcp.RetryingTcp`): it connects
once the port listens, reads nothing and drops writes meanwhile, and connects again after the peer goes."""

from __future__ import annotations

import logging
import socket
import time
from collections.abc import Callable

import pytest

from gcs.adapters.mavlink_tcp import RetryingTcp
from gcs.adapters.mavlink_wire import mavlink, open_connection

WAIT_S = 10.0


def wait_for(condition: Callable[[], bool], poll: Callable[[], object]) -> None:
    """Call ``poll`` until ``condition()`` holds (at most :data:`WAIT_S`)."""
    deadline = time.monotonic() + WAIT_S
    while not condition():
        assert time.monotonic() < deadline, "condition not reached"
        poll()
        time.sleep(0.01)


@pytest.fixture()
def closed_port():
    """A loopback TCP port that is bound but not listening yet: connections to it are refused until
    ``listen()``."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    yield server
    server.close()


def heartbeat() -> bytes:
    encoder = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    return encoder.heartbeat_encode(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0
                                    ).pack(encoder)


def test_waits_for_a_peer_that_is_not_up_yet_and_logs_it_once(closed_port, caplog) -> None:
    port = closed_port.getsockname()[1]
    with caplog.at_level(logging.INFO, logger="gcs.adapters.mavlink_tcp"):
        link = RetryingTcp(f"127.0.0.1:{port}", retry_s=0.05)
        try:
            for _ in range(5):  # refused several times: nothing read, writes dropped, no exception
                assert link.recv_msg() is None
                time.sleep(0.06)
            link.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            assert not link.connected and link.dropped_writes == 1
            closed_port.listen(1)
            wait_for(lambda: link.connected, link.recv_msg)
            peer, _ = closed_port.accept()
            with peer:
                peer.sendall(heartbeat())
                received: list = []

                def read() -> None:
                    if (message := link.recv_msg()) is not None:
                        received.append(message)

                wait_for(lambda: bool(received), read)
                assert received[0].get_type() == "HEARTBEAT" and received[0].get_srcSystem() == 1
        finally:
            link.close()
    waiting = [r for r in caplog.records if "no answer yet" in r.getMessage()]
    assert len(waiting) == 1 and waiting[0].levelno == logging.WARNING
    assert sum("connected" in r.getMessage() for r in caplog.records) == 1


def test_reconnects_after_the_peer_closes(closed_port) -> None:
    closed_port.listen(2)
    link = RetryingTcp(f"127.0.0.1:{closed_port.getsockname()[1]}", retry_s=0.05)
    try:
        wait_for(lambda: link.connected, link.recv_msg)
        first, _ = closed_port.accept()
        first.close()  # the autopilot goes away
        wait_for(lambda: not link.connected, link.recv_msg)
        wait_for(lambda: link.connected, link.recv_msg)
        second, _ = closed_port.accept()
        with second:
            link.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            parser = mavlink.MAVLink(None)
            second.settimeout(WAIT_S)
            decoded = parser.parse_buffer(second.recv(1024))
            assert decoded and decoded[0].get_type() == "HEARTBEAT"
        assert link.connects == 2
    finally:
        link.close()


def test_open_connection_gives_the_waiting_client_for_tcp(closed_port) -> None:
    connection = open_connection(f"tcp:127.0.0.1:{closed_port.getsockname()[1]}", source_system=255)
    try:
        assert isinstance(connection, RetryingTcp) and not connection.connected
    finally:
        connection.close()
