"""`sim-vehicles run` as a process: a timed run with a summary, and a clean stop on SIGINT."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
from contextlib import ExitStack

from gcs.adapters.mavlink_wire import GCS_SYSID, open_connection
from tests.e2e.processes import script
from tests.loopback import silent_port


def test_timed_run_loiters_and_writes_its_summary(tmp_path) -> None:
    out = tmp_path / "summary.json"
    with silent_port(socket.SOCK_DGRAM) as port:  # the vehicles send to it; nobody reads
        done = subprocess.run(
            [script("sim-vehicles"), "run", "--duration", "20", "--rate", "20", "--seed", "4", "--zenoh-mode", "none",
             "--mavlink", f"udpout:127.0.0.1:{port}", "--json", str(out)],
            capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "simulated 20.0 s" in done.stdout
    summary = json.loads(out.read_text())
    assert summary["steps"] == 400 and summary["simulated_s"] == 20.0
    assert summary["modes"] == {"uav1": "LOITER", "uav2": "LOITER", "uav3": "LOITER"}
    assert all(count == 20 for count in summary["reports"].values())  # t = 0, 1, ..., 19 s
    assert summary["mavlink"]["sent"] > 0


def test_sigint_stops_the_vehicles_cleanly_with_a_summary() -> None:
    gcs = open_connection("udpin:127.0.0.1:0", source_system=GCS_SYSID)
    port = gcs.port.getsockname()[1]
    nobody = ExitStack()
    zenoh_port = nobody.enter_context(silent_port())  # a peer that connects nowhere, and retries
    process = subprocess.Popen(
        [script("sim-vehicles"), "run", "--rate", "5", "--zenoh-mode", "peer", "--zenoh-connect",
         f"tcp/127.0.0.1:{zenoh_port}", "--mavlink", f"udpout:127.0.0.1:{port}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=30) is not None
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=15)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
        gcs.close()
        nobody.close()
    assert process.returncode == 130, stderr  # as a shell reports Ctrl-C, after the summary
    assert "simulated" in stdout and "uav3: mode LOITER" in stdout
    assert stderr.rstrip().endswith("sim-vehicles run: interrupted"), stderr
