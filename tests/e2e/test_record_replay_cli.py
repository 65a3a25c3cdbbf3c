"""`gcs record` and `gcs replay` as processes: the determinism of a live run's tracks, and republishing."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import time

from mcap.reader import make_reader

from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.cli import query_status
from tests.e2e.processes import script
from tests.loopback import free_tcp_port, free_udp_port


def _tracks(path) -> list[bytes]:
    return [r.payload for r in read_recording(path) if "/track/" in r.key]


def test_processing_a_recorded_demo_reproduces_the_daemons_tracks_bit_for_bit(tmp_path) -> None:
    recording, demo_json = tmp_path / "demo.mcap", tmp_path / "demo.json"
    done = subprocess.run([script("gcs"), "demo", "--duration", "40", "--rate", "10", "--record", str(recording),
                           "--json", str(demo_json), "--http", "none"], capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "rejected.late" not in json.loads(demo_json.read_text())["rejected"]  # the condition for bit-identity
    out_mcap, out_csv = tmp_path / "tracks.mcap", tmp_path / "tracks.csv"
    for out in (out_mcap, out_csv):
        done = subprocess.run([script("gcs"), "replay", str(recording), "--process", "--out", str(out)],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
    live = _tracks(recording)
    assert len(live) >= 35
    assert _tracks(out_mcap) == live
    with open(out_csv) as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == len(live) and float(rows[-1]["x_m"]) == json.loads(live[-1])["state"][0]

    planned = tmp_path / "planned.mcap"
    done = subprocess.run([script("gcs"), "replay", str(recording), "--process", "--plan", "--out", str(planned)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    live_plans = [r.key for r in read_recording(recording) if "/plan/" in r.key]
    replayed_plans = [r.key for r in read_recording(planned) if "/plan/" in r.key]
    assert _tracks(planned) == live  # planning does not change the estimates
    assert sorted(set(replayed_plans)) == ["gcs/plan/uav1", "gcs/plan/uav2", "gcs/plan/uav3"]
    # every step with a track and plannable vehicles is planned (live, a daemon behind its data only fuses some)
    assert 3 * (len(live) - 2) <= len(replayed_plans) <= 3 * len(live) and len(live_plans) <= len(replayed_plans)

    info = subprocess.run([script("gcs"), "replay", str(recording), "--info", "--json"], capture_output=True,
                          text=True, timeout=60)
    summary = json.loads(info.stdout)
    assert summary["vehicles"] == ["uav1", "uav2", "uav3"] and 39.0 <= summary["stamp_span_s"] <= 40.0
    assert {"gcs/track/target", "gcs/vehicle/uav2/report"} <= {c["key"] for c in summary["channels"]}


def test_record_finishes_on_sigint_and_replay_feeds_a_running_daemon(tmp_path) -> None:
    vehicles_endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    recording = tmp_path / "vehicles.mcap"
    # the vehicles listen and wait (up to 60 s) for a subscriber before their clock starts: nothing is lost
    vehicles = subprocess.Popen([script("sim-vehicles"), "run", "--duration", "15", "--rate", "10", "--mavlink",
                                 "none", "--zenoh-listen", vehicles_endpoint, "--zenoh-connect", vehicles_endpoint,
                                 "--wait-for-gcs", "60"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    recorder = subprocess.Popen([script("gcs"), "record", "-o", str(recording), "--zenoh-connect", vehicles_endpoint],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        vehicles.communicate(timeout=120)
    finally:
        if vehicles.poll() is None:
            vehicles.kill()
            vehicles.communicate()
    flown = vehicles
    recorder.send_signal(signal.SIGINT)
    stdout, stderr = recorder.communicate(timeout=30)
    assert flown.returncode == 0
    assert recorder.returncode == 0, stderr
    assert "recorded" in stdout
    with open(recording, "rb") as stream:  # finished: the summary is there
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics.message_count > 0
    reports = sum(1 for r in read_recording(recording) if r.key.endswith("/report"))
    assert reports == 45  # 3 vehicles x 15 s at 1 Hz

    daemon_endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    daemon = subprocess.Popen([script("gcs"), "run", "--zenoh-listen", daemon_endpoint, "--mavlink",
                               f"udpin:127.0.0.1:{free_udp_port()}", "--http", "none"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        assert query_status(ZenohSettings(connect=(daemon_endpoint,)), "gcs", 30.0) is not None
        replayed = subprocess.run([script("gcs"), "replay", str(recording), "--fast", "--zenoh-connect",
                                   daemon_endpoint], capture_output=True, text=True, timeout=60)
        deadline = time.monotonic() + 30.0  # --fast returns once published; let the daemon drain its inbox
        while True:
            status = query_status(ZenohSettings(connect=(daemon_endpoint,)), "gcs", 10.0)
            if status.counters.get("accepted.report", 0) >= 45 or time.monotonic() > deadline:
                break
            time.sleep(0.2)
    finally:
        daemon.send_signal(signal.SIGINT)
        daemon.communicate(timeout=30)
    assert replayed.returncode == 0, replayed.stderr
    assert "report 45" in replayed.stdout
    assert status.counters["accepted.report"] == 45
    assert not any(k.startswith("rejected.") for k in status.counters), status.counters
