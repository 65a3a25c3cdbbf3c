"""`gcs demo`, `gcs run` and `gcs status` as processes."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess

from mcap.reader import make_reader

from gcs.scenarios import load_scenario
from gcs.cli_errors import BROKEN_PIPE_STATUS
from tests.e2e.processes import output_read_by_nobody as _output_read_by_nobody, script, stop
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
    assert f"target seen by at least one UAV in {summary['seen_any']}/20" in done.stdout
    assert "demo: wang2012_urban" in done.stdout and "compare:" not in done.stdout
    # a command is flown at least the steps' wait after its step (vehicle time), and within the plan's horizon
    assert 0.0 < summary["command_age_ms_median"] <= summary["command_age_ms_p99"] < 15_000.0, summary
    assert f"command age median {summary['command_age_ms_median']:.0f} ms" in done.stdout
    assert re.search(r"decision step's stamp\): (the loop keeps up|commands flown late)", done.stdout)
    assert not summary["interrupted"] and "interrupted" not in done.stdout + done.stderr
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
        shown_text = subprocess.run([script("gcs"), "status", "--zenoh-connect", endpoint, "--timeout", "20"],
                                    capture_output=True, text=True, timeout=60)
        cut_short = _output_read_by_nobody([script("gcs"), "status", "--zenoh-connect", endpoint, "--timeout", "20"])
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
    # the status read as text: times in UTC, no raw nanoseconds
    assert shown_text.returncode == 0, shown_text.stderr
    assert re.search(r"status at \d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ, last track none", shown_text.stdout), shown_text.stdout
    assert not re.search(r"\d{19}", shown_text.stdout), shown_text.stdout
    assert cut_short == (BROKEN_PIPE_STATUS, ""), cut_short  # `gcs status | head`: quiet, no traceback
    # Ctrl-C: the daemon stops cleanly, says so, and exits 130 as a shell expects of Ctrl-C
    assert daemon.returncode == 130, stderr[-3000:]
    assert "gcs run: interrupted" in stderr and "live map on http://127.0.0.1:" in stderr
    assert "daemon stopped: no decision step (no vehicle report came in); 0 steering commands sent over MAVLink" \
        in stderr, stderr[-3000:]
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



def test_demo_stopped_by_ctrl_c_says_so_with_the_summary_of_the_steps_flown(tmp_path) -> None:
    out = tmp_path / "demo.json"
    temporary = tmp_path / "tmp"  # the demo's temporary folder: what it leaves there is seen
    temporary.mkdir()
    demo = subprocess.Popen([script("gcs"), "demo", "--duration", "300", "--rate", "10", "--http", "none",
                             "--json", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "TMPDIR": str(temporary)})
    try:
        progress = Lines(demo.stderr)
        progress.wait_for(r"^step   30/300 ", timeout_s=120)  # flying: the progress line (a line every 30 steps)
        demo.send_signal(signal.SIGINT)
        demo.wait(timeout=60)
        stdout, stderr = demo.stdout.read(), progress.rest()
    finally:
        stop(demo)
    summary = json.loads(out.read_text())
    assert demo.returncode == 130, stderr[-3000:]
    assert summary["interrupted"] is True and 30 <= summary["steps"] < 300
    assert f"interrupted after {summary['steps']} of 300 steps: the figures below are of the steps flown" in stdout
    assert f"target seen by at least one UAV in {summary['seen_any']}/{summary['steps']}" in stdout
    assert stderr.rstrip().endswith("gcs demo: interrupted"), stderr[-3000:]
    assert list(temporary.iterdir()) == []  # the simulator's output, stopped as asked, is not left behind


def test_demo_whose_output_nobody_reads_ends_quietly() -> None:
    # `gcs demo | head -0`: the first line finds no reader; the demo closes what it opened and ends, status 141
    code, stderr = _output_read_by_nobody([script("gcs"), "demo", "--duration", "5", "--http", "none"])
    assert code == BROKEN_PIPE_STATUS and "Traceback" not in stderr, stderr[-3000:]
