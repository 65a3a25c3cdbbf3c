"""A UDP port to listen on is ours alone: refused while another program holds it, and refused to others
while we hold it (:func:`gcs.adapters.mavlink_wire.bind_udp_exclusively`).

pymavlink's ``udpin`` binds with ``SO_REUSEADDR``, as MAVProxy's ``--master=udpin:`` does: two such
sockets share a port on Linux, and the later one takes the datagrams. Each case below holds the port
as such a program would and checks both orders.
"""

from __future__ import annotations

import socket

import pytest

from gcs.adapters.mavlink_wire import GCS_SYSID, mavutil, open_connection
from tests.loopback import LOCALHOST


def _pymavlink_udpin(port: int):
    """A listener as MAVProxy's ``--master=udpin:`` opens it (pymavlink, SO_REUSEADDR)."""
    return mavutil.mavlink_connection(f"udpin:{LOCALHOST}:{port}", source_system=GCS_SYSID)


@pytest.mark.parametrize("host", [LOCALHOST, "0.0.0.0"])
def test_a_port_a_pymavlink_listener_holds_is_refused_naming_it(host: str) -> None:
    other = _pymavlink_udpin(0)
    port = other.port.getsockname()[1]
    try:
        with pytest.raises(ValueError, match=rf"UDP port {port} on {host} is in use by another program"):
            open_connection(f"udpin:{host}:{port}", source_system=GCS_SYSID)
    finally:
        other.close()
    open_connection(f"udpin:{host}:{port}", source_system=GCS_SYSID).close()  # free again: taken


def test_a_port_a_plain_socket_holds_is_refused() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind((LOCALHOST, 0))
        port = held.getsockname()[1]
        with pytest.raises(ValueError, match=f"UDP port {port} on {LOCALHOST} is in use"):
            open_connection(f"udp:{LOCALHOST}:{port}", source_system=GCS_SYSID)


def test_while_we_listen_a_pymavlink_listener_cannot_bind_beside_us() -> None:
    ours = open_connection(f"udpin:{LOCALHOST}:0", source_system=GCS_SYSID)
    port = ours.port.getsockname()[1]
    try:
        with pytest.raises(OSError):
            _pymavlink_udpin(port).close()
        # and the port works as pymavlink's own: a vehicle's heartbeat in, our reply back to its socket
        vehicle = open_connection(f"udpout:{LOCALHOST}:{port}", source_system=7)
        try:
            vehicle.mav.heartbeat_send(1, 3, 0, 0, 4)
            heard = ours.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
            assert heard is not None and heard.get_srcSystem() == 7
            ours.mav.heartbeat_send(6, 8, 0, 0, 4)
            answer = vehicle.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
            assert answer is not None and answer.get_srcSystem() == GCS_SYSID
        finally:
            vehicle.close()
    finally:
        ours.close()
