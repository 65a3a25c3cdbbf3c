"""The parts of the SITL harness that need no SITL: finding the binary, the namespace command, the relay that cuts a
link."""

from __future__ import annotations

import socket
import stat
import time
from pathlib import Path

import pytest

from benchmarks.sitl.arduplane import ArduPlaneSitl, defaults_beside, find_binary
from benchmarks.sitl.namespace import in_private_network, namespace_command
from benchmarks.sitl.relay import TcpRelay


def test_the_binary_must_be_an_executable_file(tmp_path) -> None:
    with pytest.raises(ValueError, match="not an executable file"):
        find_binary(tmp_path / "arduplane")
    binary = tmp_path / "arduplane"
    binary.write_text("#!/bin/sh\n")
    with pytest.raises(ValueError, match="not an executable file"):
        find_binary(binary)
    binary.chmod(binary.stat().st_mode | stat.S_IXUSR)
    assert find_binary(binary) == binary.resolve() and defaults_beside(binary) is None
    (tmp_path / "plane.parm").write_text("AIRSPEED_MAX 30\n")
    assert defaults_beside(binary) == tmp_path / "plane.parm"


def test_instances_take_their_own_ports() -> None:
    second = ArduPlaneSitl(Path("/bin/true"), 1, 2, (0.0, 0.0, 0.0, 0.0))  # not started
    try:
        assert [second.port(k) for k in range(3)] == [5770, 5772, 5773]
        assert second.connection(2) == "tcp:127.0.0.1:5773"
    finally:
        second.stop()


def test_the_namespace_command_brings_up_loopback_before_the_program() -> None:
    command = namespace_command(["prog", "--flag"])
    assert command[:2] in (["unshare", "-n"], ["unshare", "-rn"])
    assert command[-2:] == ["prog", "--flag"] and "ip link set lo up" in command[command.index("-c") + 1]
    assert not in_private_network()  # the tests run on the machine's own network


def test_the_relay_copies_both_ways_and_a_cut_refuses_until_restored() -> None:
    upstream = socket.create_server(("127.0.0.1", 0))
    relay = TcpRelay(upstream.getsockname()[:2])
    try:
        client = socket.create_connection(("127.0.0.1", relay.port), timeout=5)
        far, _ = upstream.accept()
        client.sendall(b"ping")
        far.settimeout(5)
        assert far.recv(4) == b"ping"
        far.sendall(b"pong")
        assert client.recv(4) == b"pong"
        relay.cut()
        assert far.recv(4) == b""  # the autopilot's side closed
        with pytest.raises(OSError):
            socket.create_connection(("127.0.0.1", relay.port), timeout=1)
        relay.restore()
        deadline = time.monotonic() + 5
        while True:
            try:
                again = socket.create_connection(("127.0.0.1", relay.port), timeout=1)
                break
            except OSError:
                assert time.monotonic() < deadline
                time.sleep(0.05)
        far2, _ = upstream.accept()
        again.sendall(b"back")
        far2.settimeout(5)
        assert far2.recv(4) == b"back" and relay.cuts == 1
        for sock in (client, far, again, far2):
            sock.close()
    finally:
        relay.close()
        upstream.close()
