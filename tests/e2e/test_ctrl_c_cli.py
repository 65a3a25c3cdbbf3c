"""Ctrl-C ends every long-running command the same way: cleanly, `<command>: interrupted`, status 130.

A terminal's Ctrl-C sends SIGINT to the whole foreground process group (a command's worker
processes too): each command here runs in its own group and the group gets the signal, once
the command shows it is at work. `gcs run`, `gcs demo`, `gcs record`, `gcs replay --view` and
`sim-vehicles run` / `payload` are stopped the same way in their own tests.
"""

from __future__ import annotations

import os
import signal
import subprocess

import pytest

from tests.e2e.processes import script
from tests.loopback import ANY_PORT_ENDPOINT, Lines

WORKING = {
    "gcs router": (["gcs", "router", "--zenoh-listen", ANY_PORT_ENDPOINT], "stdout", r"^router listening on tcp/"),
}
"""Each command, and the line (on which stream) that shows it at work."""


@pytest.mark.parametrize("command", WORKING)
def test_ctrl_c_stops_the_command_saying_interrupted_with_status_130(command: str) -> None:
    (program, *argv), stream, working = WORKING[command]
    process = subprocess.Popen([script(program), *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        lines = Lines(getattr(process, stream))
        lines.wait_for(working, timeout_s=120)
        os.killpg(process.pid, signal.SIGINT)
        process.wait(timeout=60)
        rest = lines.rest()
        stderr = rest if stream == "stderr" else process.stderr.read()
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, stderr[-3000:]
    assert stderr.rstrip().endswith(f"{command}: interrupted") and "Traceback" not in stderr, stderr[-3000:]
