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
from gcs.recordings.record import NO_PEER_WARN_S
from tests.e2e.processes import script, stop
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, Lines, daemon_up, silent_port


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
    """The README's flow without a daemon: the recorder listens where the vehicles connect."""
    recording = tmp_path / "vehicles.mcap"
    recorder = subprocess.Popen([script("gcs"), "record", "-o", str(recording), "--zenoh-listen", ANY_PORT_ENDPOINT],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out = Lines(recorder.stdout)
        vehicles_endpoint = out.wait_for(r"recording gcs/\*\* to .*; listening on (tcp/127\.0\.0\.1:\d+)$").group(1)
        # the vehicles wait (up to 60 s) for a subscriber before their clock starts: nothing is lost
        flown = subprocess.run([script("sim-vehicles"), "run", "--duration", "15", "--rate", "10", "--mavlink", "none",
                                "--zenoh-connect", vehicles_endpoint, "--wait-for-gcs", "60"],
                               capture_output=True, text=True, timeout=120)
        recorder.send_signal(signal.SIGINT)
        recorder.wait(timeout=30)
        stdout, stderr = out.rest(), recorder.stderr.read()
    finally:
        stop(recorder)
    assert flown.returncode == 0, flown.stderr
    assert recorder.returncode == 130, stderr  # Ctrl-C: the recording finished, and the status says how it ended
    assert "gcs record: interrupted" in stderr and "recorded" in stdout and "no zenoh peer" not in stderr
    with open(recording, "rb") as stream:  # finished: the summary is there
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics.message_count > 0
    reports = sum(1 for r in read_recording(recording) if r.key.endswith("/report"))
    assert reports == 45  # 3 vehicles x 15 s at 1 Hz

    daemon = subprocess.Popen([script("gcs"), "run", "--zenoh-listen", ANY_PORT_ENDPOINT, "--mavlink", ANY_UDP,
                               "--http", "none"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        daemon_endpoint, _ = daemon_up(Lines(daemon.stderr))
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
        stop(daemon, timeout=30)
    assert replayed.returncode == 0, replayed.stderr
    assert "report 45" in replayed.stdout
    assert status.counters["accepted.report"] == 45
    assert not any(k.startswith("rejected.") for k in status.counters), status.counters


def test_a_recorder_with_nobody_to_record_says_so_and_fails_unless_empty_is_allowed(tmp_path) -> None:
    """Its default endpoint is the daemon's; with nobody there it warns, naming the endpoint and the fix, and an
    empty recording is exit status 1 (0 with --allow-empty)."""
    with silent_port() as port:  # bound, never listened on: where a daemon would be
        endpoint = f"tcp/127.0.0.1:{port}"
        runs = {allow: subprocess.run([script("gcs"), "record", "-o", str(tmp_path / f"empty{allow}.mcap"),
                                       "--zenoh-connect", endpoint, "--duration", str(NO_PEER_WARN_S + 1.0),
                                       *(["--allow-empty"] if allow else [])],
                                      capture_output=True, text=True, timeout=60) for allow in (False, True)}
    for allow, done in runs.items():
        assert done.returncode == (0 if allow else 1), done.stderr
        assert "recorded 0 messages" in done.stdout and "Traceback" not in done.stderr
        assert f"no zenoh peer or router reached after {NO_PEER_WARN_S:g} s (connecting to {endpoint})" in done.stderr
        assert "--zenoh-listen tcp/127.0.0.1:7447, where sim-vehicles run connects" in done.stderr
        assert ("--allow-empty accepts an empty recording" in done.stderr) is not allow
        assert list(read_recording(tmp_path / f"empty{allow}.mcap")) == []  # a valid, finished, empty file
