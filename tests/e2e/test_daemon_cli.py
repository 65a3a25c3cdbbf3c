"""`gcs demo`, `gcs run` and `gcs status` as processes."""

from __future__ import annotations

import json
import signal
import subprocess

from mcap.reader import make_reader

from gcs.scenarios import load_scenario
from tests.e2e.processes import script
from tests.figures import one_scan_bound_m, track_error_window
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, silent_port, Lines, daemon_up


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
    assert 0 < summary["seen_any"] <= 20 and summary["rmse_m"] is not None
    floor_m, one_detection_m = track_error_window(load_scenario("wang2012_urban"))  # tests/figures.py
    assert floor_m < summary["rmse_m"] < one_detection_m, (floor_m, summary["rmse_m"], one_detection_m)
    assert "seen by at least one UAV" in done.stdout and "demo: wang2012_urban" in done.stdout
    # a command is flown at least the steps' wait after its step (vehicle time), and within the plan's horizon
    assert 0.0 < summary["command_age_ms_median"] <= summary["command_age_ms_p99"] < 15_000.0, summary
    assert "command age (vehicle time flown less the decision step's stamp) median" in done.stdout
    assert "live map: http://127.0.0.1:" in done.stdout and "foxglove: ws://127.0.0.1:" in done.stdout
    with open(foxglove, "rb") as stream:  # the map's channels, in Foxglove's schemas
        channels = {c.topic: c for c in make_reader(stream).get_summary().channels.values()}
    assert {"/map/vehicles/uav1", "/map/target/estimate", "/map/target/truth", "/map/world"} <= set(channels)


def test_run_answers_status_and_stops_cleanly_on_sigint_finishing_its_recording(tmp_path) -> None:
    recording = tmp_path / "run.mcap"
    daemon = subprocess.Popen([script("gcs"), "run", "--zenoh-listen", ANY_PORT_ENDPOINT, "--record", str(recording),
                               "--mavlink", ANY_UDP, "--http", "127.0.0.1:0"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        lines = Lines(daemon.stderr)
        endpoint, ports = daemon_up(lines)  # where the system let it listen
        assert set(ports) == {"uav1", "uav2", "uav3"} and len(set(ports.values())) == 1 and endpoint
        status = subprocess.run([script("gcs"), "status", "--json", "--zenoh-connect", endpoint, "--timeout", "20"],
                                capture_output=True, text=True, timeout=60)
        daemon.send_signal(signal.SIGINT)
        daemon.wait(timeout=20)
        stderr = lines.rest()
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.wait()
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
    with silent_port() as port:  # bound, never listened on: nobody answers there
        done = subprocess.run([script("gcs"), "status", "--zenoh-connect", f"tcp/127.0.0.1:{port}",
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
    # tracks from the bearings alone (ML start, then the VG-UKF): 40 scans fused beat the Cramer-Rao bound of
    # one scan from where the UAVs start (zuo2021 eq. 2's noise at each range, bearings only)
    assert summary["scored_steps"] >= 35 and summary["rmse_m"] < one_scan_bound_m(load_scenario("zuo2021_aoa")), \
        summary

