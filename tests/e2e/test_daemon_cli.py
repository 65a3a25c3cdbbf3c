"""`gcs demo`, `gcs run` and `gcs status` as processes."""

from __future__ import annotations

import json
import signal
import subprocess

from mcap.reader import make_reader

from tests.e2e.processes import script
from tests.loopback import free_tcp_port, free_udp_port


def test_demo_runs_daemon_and_vehicles_and_writes_the_summary(tmp_path) -> None:
    out = tmp_path / "demo.json"
    foxglove = tmp_path / "map.mcap"
    done = subprocess.run([script("gcs"), "demo", "--duration", "20", "--rate", "10", "--json", str(out),
                           "--http", "127.0.0.1:0", "--foxglove", "127.0.0.1:0", "--foxglove-mcap", str(foxglove)],
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(out.read_text())
    assert summary["steps"] == 20
    assert set(summary["seen_per_uav"]) == {"uav1", "uav2", "uav3"}
    assert 0 < summary["seen_any"] <= 20 and summary["rmse_m"] is not None and summary["rmse_m"] > 0
    assert "seen by at least one UAV" in done.stdout and "demo: wang2012_urban" in done.stdout
    assert "live map: http://127.0.0.1:" in done.stdout and "foxglove: ws://127.0.0.1:" in done.stdout
    with open(foxglove, "rb") as stream:  # the map's channels, in Foxglove's schemas
        channels = {c.topic: c for c in make_reader(stream).get_summary().channels.values()}
    assert {"/map/vehicles/uav1", "/map/target/estimate", "/map/target/truth", "/map/world"} <= set(channels)


def test_run_answers_status_and_stops_cleanly_on_sigint_finishing_its_recording(tmp_path) -> None:
    endpoint, recording = f"tcp/127.0.0.1:{free_tcp_port()}", tmp_path / "run.mcap"
    daemon = subprocess.Popen([script("gcs"), "run", "--zenoh-listen", endpoint, "--record", str(recording),
                               "--mavlink", f"udpin:127.0.0.1:{free_udp_port()}", "--http", "127.0.0.1:0"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        status = subprocess.run([script("gcs"), "status", "--json", "--zenoh-connect", endpoint, "--timeout", "20"],
                                capture_output=True, text=True, timeout=60)
        daemon.send_signal(signal.SIGINT)
        _, stderr = daemon.communicate(timeout=20)
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.communicate()
    assert status.returncode == 0, status.stderr
    shown = json.loads(status.stdout)
    assert shown["scenario"] == "wang2012_urban"
    assert [v["vehicle_id"] for v in shown["vehicles"]] == ["uav1", "uav2", "uav3"]
    assert {v["link"] for v in shown["vehicles"]} == {"unknown"}
    assert daemon.returncode == 0, stderr[-3000:]
    assert "daemon stopped" in stderr and "live map on http://127.0.0.1:" in stderr
    with open(recording, "rb") as stream:  # finished on SIGINT: the summary is written
        assert make_reader(stream).get_summary() is not None


def test_status_without_a_daemon_fails_clearly() -> None:
    done = subprocess.run([script("gcs"), "status", "--zenoh-connect", f"tcp/127.0.0.1:{free_tcp_port()}",
                           "--timeout", "1"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    assert "no daemon answered" in done.stderr


def test_demo_in_the_bearing_only_mode(tmp_path) -> None:
    out = tmp_path / "aoa.json"
    done = subprocess.run([script("gcs"), "demo", "--scenario", "zuo2021_aoa", "--duration", "40", "--rate", "10",
                           "--json", str(out), "--http", "none"], capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(out.read_text())
    assert summary["steps"] == 40 and summary["seen_any"] == 40  # an open field: always in sight
    # tracks from the bearings alone (ML start, then the VG-UKF), nearer than the 9 km the target is away
    assert summary["scored_steps"] >= 35 and summary["rmse_m"] < 9000.0
