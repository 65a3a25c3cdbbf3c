"""`gcs record` and `gcs replay` as processes: the determinism of a live run's tracks, recording in each topology
(without a daemon, beside one, through a router), republishing, and a recording that holds no vehicle."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import time
from contextlib import ExitStack

import pytest

from mcap.reader import make_reader

from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.cli import query_status
from gcs.config.fingerprint import scenario_fingerprint
from gcs.scenarios import load_scenario
from tests.e2e.processes import script, stop
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, Lines, daemon_up, silent_port

URBAN = {"name": "wang2012_urban", "fingerprint": scenario_fingerprint(load_scenario("wang2012_urban"))}


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
    assert summary["scenario"] == URBAN  # the daemon's own, kept by gcs run --record
    assert {"gcs/track/target", "gcs/vehicle/uav2/report"} <= {c["key"] for c in summary["channels"]}


def _recorder(tmp_path, name: str, *zenoh: str) -> tuple[subprocess.Popen, Lines, str]:
    """A ``gcs record`` process, once it says where it records (the endpoint it listens on or joined)."""
    recorder = subprocess.Popen([script("gcs"), "record", "-o", str(tmp_path / name), *zenoh],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = Lines(recorder.stdout)
    where = out.wait_for(r"^recording gcs/\*\* to .* as a zenoh \w+; (listening on|joined) (tcp/127\.0\.0\.1:\d+)")
    return recorder, out, where.group(2)


def _fly(tmp_path, *zenoh: str) -> dict:
    """``sim-vehicles run`` for 15 s of flight at 10x with no MAVLink; its summary (what each vehicle published)."""
    summary = tmp_path / "vehicles.json"
    flown = subprocess.run([script("sim-vehicles"), "run", "--duration", "15", "--rate", "10", "--mavlink", "none",
                            "--wait-for-gcs", "60", "--json", str(summary), *zenoh],
                           capture_output=True, text=True, timeout=120)
    assert flown.returncode == 0, flown.stderr
    return json.loads(summary.read_text())


def _finish(recorder: subprocess.Popen, out: Lines) -> tuple[str, str]:
    """Wait for every vehicle to leave (its token withdrawn after all it published), then stop the recorder as a
    user does (Ctrl-C); its stdout and stderr."""
    for _ in range(3):
        out.wait_for(r"^vehicle uav\d left$")
    recorder.send_signal(signal.SIGINT)
    recorder.wait(timeout=30)
    return out.rest(), recorder.stderr.read()


def _check_recording(path, flown: dict, stdout: str, stderr: str) -> None:
    """Every message the vehicles published is in the recording, which names their scenario."""
    assert "Traceback" not in stderr and "holds no vehicle report" not in stderr, stderr
    assert [line for line in stdout.splitlines() if line.startswith("hearing vehicle")] == [
        "hearing vehicle uav1", "hearing vehicle uav2", "hearing vehicle uav3"]
    assert f"scenario wang2012_urban (fingerprint {URBAN['fingerprint']}), as vehicle" in stdout
    with open(path, "rb") as stream:  # finished: the summary is there
        assert make_reader(stream).get_summary() is not None
    kinds: dict[tuple[str, str], int] = {}
    for record in read_recording(path):
        parts = record.key.split("/")
        if parts[1] == "vehicle":
            kinds[(parts[2], parts[3])] = kinds.get((parts[2], parts[3]), 0) + 1
    for vehicle in ("uav1", "uav2", "uav3"):
        assert kinds[(vehicle, "report")] == flown["reports"][vehicle] == 15
        assert kinds[(vehicle, "nav")] == flown["nav_reports"][vehicle]
        assert kinds[(vehicle, "scenario")] == 15  # announced with each report
        assert kinds[(vehicle, "alive")] == 2  # declared, withdrawn
    assert f"recorded {sum(1 for _ in read_recording(path))} messages to {path}: 45 vehicle reports from uav1, " \
           "uav2, uav3, scenario wang2012_urban" in stdout


def test_without_a_daemon_the_recorder_is_where_the_vehicles_connect_and_replay_feeds_a_daemon(tmp_path) -> None:
    """The README's flow without a daemon: the recorder listens where the vehicles connect."""
    recording = tmp_path / "vehicles.mcap"
    recorder, out, endpoint = _recorder(tmp_path, recording.name, "--zenoh-listen", ANY_PORT_ENDPOINT)
    try:
        flown = _fly(tmp_path, "--zenoh-connect", endpoint)
        stdout, stderr = _finish(recorder, out)
    finally:
        stop(recorder)
    assert recorder.returncode == 130, stderr  # Ctrl-C: the recording finished, and the status says how it ended
    assert "gcs record: interrupted" in stderr
    _check_recording(recording, flown, stdout, stderr)

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
            if status.counters.get("accepted.scenario", 0) >= 45 or time.monotonic() > deadline:
                break
            time.sleep(0.2)
    finally:
        stop(daemon, timeout=30)
    assert replayed.returncode == 0, replayed.stderr
    assert "report 45" in replayed.stdout and "scenario 45" in replayed.stdout
    assert status.counters["accepted.report"] == 45 and status.counters["accepted.scenario"] == 45
    assert not any(k.startswith("rejected.") for k in status.counters), status.counters


@pytest.mark.parametrize("topology", ["beside a daemon", "through a router"])
def test_the_recorder_joining_a_daemon_or_router_hears_every_vehicle_message(tmp_path, topology: str) -> None:
    """The README's other flows: ``gcs record`` joins the daemon (a peer, which the vehicles connect to), or the
    router every program is a client of; either hands it the vehicles' messages."""
    with ExitStack() as stack:
        zenoh: list[str] = []
        if topology == "through a router":
            router = subprocess.Popen([script("gcs"), "router", "--zenoh-listen", ANY_PORT_ENDPOINT],
                                      stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            stack.callback(stop, router)
            hub = Lines(router.stdout).wait_for(r"^router listening on (tcp/127\.0\.0\.1:\d+)").group(1)
            zenoh = ["--zenoh-mode", "client", "--zenoh-connect", hub]
        daemon = subprocess.Popen([script("gcs"), "run", "--mavlink", ANY_UDP, "--http", "none",
                                   *(zenoh or ["--zenoh-listen", ANY_PORT_ENDPOINT])],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        stack.callback(stop, daemon, 30)
        daemon_endpoint, _ = daemon_up(Lines(daemon.stderr))
        hub = hub if zenoh else daemon_endpoint
        recorder, out, joined = _recorder(tmp_path, "traffic.mcap", "--zenoh-connect", hub)
        stack.callback(stop, recorder)
        assert joined == hub and "as a zenoh client" in out.seen[-1]
        flown = _fly(tmp_path, *(zenoh or ["--zenoh-connect", hub]))
        stdout, stderr = _finish(recorder, out)
    assert recorder.returncode == 130, stderr  # Ctrl-C: the recording finished, and the status says how it ended
    assert "gcs record: interrupted" in stderr
    _check_recording(tmp_path / "traffic.mcap", flown, stdout, stderr)
    processed = subprocess.run([script("gcs"), "replay", str(tmp_path / "traffic.mcap"), "--process"],
                               capture_output=True, text=True, timeout=120)
    assert processed.returncode == 0, processed.stderr
    assert "WARNING" not in processed.stderr  # the recorded scenario is the shipped one
    assert "accepted.report 45" in processed.stdout and "not kept: --out" in processed.stdout


def test_a_recorder_with_nobody_to_record_says_so_and_fails_unless_empty_is_allowed(tmp_path) -> None:
    """Joining where nobody listens is an error at once; a recording that ends without any vehicle report is a
    warning and exit status 1 (0 with --allow-empty), and processing it is one line and exit status 1."""
    with silent_port() as port:  # bound, never listened on: where a daemon would be
        endpoint = f"tcp/127.0.0.1:{port}"
        joining = subprocess.run([script("gcs"), "record", "-o", str(tmp_path / "nobody.mcap"), "--zenoh-connect",
                                  endpoint], capture_output=True, text=True, timeout=60)
    assert joining.returncode == 1 and len(joining.stderr.splitlines()) == 1, joining.stderr
    assert joining.stderr.startswith(f"gcs record: error: nobody answers on {endpoint} (")
    assert "start gcs run or gcs router there first" in joining.stderr
    runs = {allow: subprocess.run([script("gcs"), "record", "-o", str(tmp_path / f"empty{allow}.mcap"),
                                   "--zenoh-listen", ANY_PORT_ENDPOINT, "--duration", "1",
                                   *(["--allow-empty"] if allow else [])],
                                  capture_output=True, text=True, timeout=60) for allow in (False, True)}
    for allow, done in runs.items():
        assert done.returncode == (0 if allow else 1), done.stderr
        assert "recorded 0 messages" in done.stdout and "Traceback" not in done.stderr
        assert f"the recording {tmp_path / f'empty{allow}.mcap'} holds no vehicle report" in done.stderr
        assert ("--allow-empty accepts it" in done.stderr) is not allow
        assert list(read_recording(tmp_path / f"empty{allow}.mcap")) == []  # a valid, finished, empty file
    processed = subprocess.run([script("gcs"), "replay", str(tmp_path / "emptyFalse.mcap"), "--process"],
                               capture_output=True, text=True, timeout=60)
    assert processed.returncode == 1
    assert processed.stderr.splitlines() == [f"gcs replay: error: {tmp_path / 'emptyFalse.mcap'} holds no vehicle "
                                             "report, so there are no tracks to estimate (gcs replay "
                                             f"{tmp_path / 'emptyFalse.mcap'} --info lists what it holds)"]
