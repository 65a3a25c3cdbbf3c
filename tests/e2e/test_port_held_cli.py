"""`gcs run` and `sim-vehicles run` refuse a UDP port another program listens on: one line naming it, status 1."""

from __future__ import annotations

import subprocess

import pytest

from gcs.adapters.mavlink_wire import GCS_SYSID, mavutil
from tests.e2e.processes import script
from tests.loopback import ANY_PORT_ENDPOINT, LOCALHOST

COMMANDS = {
    "gcs run": ["gcs", "run", "--zenoh-listen", ANY_PORT_ENDPOINT, "--http", "none"],
    "sim-vehicles run": ["sim-vehicles", "run", "--zenoh-mode", "none", "--duration", "5"],
}


@pytest.mark.parametrize("command", COMMANDS)
def test_a_udp_port_mavproxy_holds_is_refused_in_one_line(command: str) -> None:
    program, *options = COMMANDS[command]
    held = mavutil.mavlink_connection(f"udpin:{LOCALHOST}:0", source_system=GCS_SYSID)  # as mavproxy --master=udpin:
    port = held.port.getsockname()[1]
    try:
        done = subprocess.run([script(program), *options, "--mavlink", f"udpin:{LOCALHOST}:{port}"],
                              capture_output=True, text=True, timeout=120)
    finally:
        held.close()
    errors = [line for line in done.stderr.splitlines() if ": error: " in line]
    assert done.returncode == 1, done.stderr
    assert len(errors) == 1 and errors[0].startswith(f"{command}: error: "), done.stderr
    assert f"UDP port {port} on {LOCALHOST} is in use by another program" in errors[0]
    assert "Traceback" not in done.stderr
