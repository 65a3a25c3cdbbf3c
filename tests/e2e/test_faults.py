"""Faults, with the real processes: a vehicle process killed, the Zenoh router restarted, the recorder killed.

Every port is the one the system chose (a listener on port 0, read back); the restarted router takes the
port its predecessor had.

The daemon runs in a thread of the test (so that its registry and records can
be watched); vehicles, router and recorder are the ``sim-vehicles`` and
``gcs`` console scripts, killed with SIGKILL, which no handler can soften.
"""

from __future__ import annotations

import json
import signal
import subprocess
import threading
import time
from contextlib import ExitStack
from pathlib import Path

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES
from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings, declare_publisher, listening_endpoints, open_session, publish
from gcs.daemon.app import Daemon, DaemonOptions
from protocols.keys import report_key
from protocols.messages import SensorReport
from tests.e2e.processes import script, stop
from tests.integration.sim_harness import SCENARIO, WORLD
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

RATE = 4.0
ROSTER = tuple(v.id for v in SCENARIO.vehicles)
GUIDED = ARDUPLANE_MODES["GUIDED"]


def wait_for(condition, timeout_s: float, what: str, poll_s: float = 0.05) -> float:
    """Wait until ``condition()``; returns the monotonic time it first held (AssertionError on timeout)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return time.monotonic()
        time.sleep(poll_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def _running_daemon(stack: ExitStack, zenoh: ZenohSettings, mavlink: dict[str, str]) -> Daemon:
    """The daemon in a thread (a cheap planner, planned inline), opened first (its ports are known on return),
    stopped and joined when the stack closes."""
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=zenoh, mavlink=mavlink, planner="orbit",
                                                   plan_runner="inline"))
    daemon.open()
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()

    def join() -> None:
        daemon.stop()
        thread.join(timeout=20)
        assert not thread.is_alive(), "the daemon did not stop"

    stack.callback(join)
    return daemon


def _vehicle(stack: ExitStack, tmp_path: Path, vehicle: str | None, mavlink: str, zenoh: list[str],
             start_at: float, tag: str = "") -> subprocess.Popen:
    only = ["--only", vehicle] if vehicle else []
    log = open(tmp_path / f"{vehicle or 'vehicles'}{tag}.log", "w")
    stack.callback(log.close)
    process = subprocess.Popen(
        [script("sim-vehicles"), "run", *only, "--seed", "3", "--rate", str(RATE), "--epoch-ns", "0",
         "--start-at", str(start_at), "--mavlink", mavlink, *zenoh], stdout=subprocess.DEVNULL, stderr=log)
    stack.callback(stop, process)
    return process


def _planned_for(daemon: Daemon, vehicles: tuple[str, ...], after: int = 0) -> int:
    return sum(1 for plan in daemon.plans[after:] if plan.vehicles == vehicles)


def test_a_killed_vehicle_process_is_lost_by_its_token_planned_around_and_readmitted(tmp_path) -> None:
    with ExitStack() as stack:
        daemon = _running_daemon(stack, ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
                                 {v: ANY_UDP for v in ROSTER})
        endpoint, ports = daemon_ports(daemon)
        start_at = time.time() + 3.0  # one clock for every vehicle process, the restarted one too
        processes = {v: _vehicle(stack, tmp_path, v, f"udpout:127.0.0.1:{ports[v]}", ["--zenoh-connect", endpoint],
                                 start_at) for v in ROSTER}
        wait_for(lambda: _planned_for(daemon, ROSTER) >= 5, 90, "plans for all three vehicles")

        processes["uav3"].kill()
        heartbeat_fresh_at_loss = []

        def lost() -> bool:
            now = time.monotonic()
            if daemon.registry.alive("uav3", now):
                return False
            heartbeat_fresh_at_loss.append(daemon.commander.alive("uav3", now, daemon.commander.link_timeout_s))
            return True

        wait_for(lost, 15, "uav3 lost", poll_s=0.01)
        # lost by its liveliness token, not by MAVLink's 5 s timeout: its last heartbeat was still fresh then
        assert heartbeat_fresh_at_loss == [True]
        plans_at_loss = len(daemon.plans)
        wait_for(lambda: _planned_for(daemon, ("uav1", "uav2"), plans_at_loss) >= 5, 60, "plans without uav3")

        _vehicle(stack, tmp_path, "uav3", f"udpout:127.0.0.1:{ports['uav3']}", ["--zenoh-connect", endpoint],
                 start_at, tag="-restarted")
        plans_at_return = len(daemon.plans)
        wait_for(lambda: _planned_for(daemon, ROSTER, plans_at_return) >= 3, 90, "uav3 planned for again")
        wait_for(lambda: daemon.commander.link("uav3").custom_mode == GUIDED, 30, "uav3 commanded into GUIDED")
        status = daemon.status(time.monotonic())
    assert [v.link for v in status.vehicles] == ["ok", "ok", "ok"]
    counters = status.counters
    assert not any(name.startswith("errors.") for name in counters), counters
    rejected = {k: v for k, v in counters.items() if k.startswith("rejected.")}
    assert set(rejected) <= {"rejected.late"}, counters  # the restarted process joins the same clock
    assert counters["accepted.report"] >= 30


def test_a_client_mode_daemon_reconnects_when_the_router_restarts(tmp_path) -> None:
    def start_router(tag: str, endpoint: str) -> tuple[subprocess.Popen, str]:
        log = open(tmp_path / f"router{tag}.log", "w")
        stack.callback(log.close)
        router = subprocess.Popen([script("gcs"), "router", "--zenoh-listen", endpoint],
                                  stdout=subprocess.PIPE, stderr=log, text=True)
        stack.callback(stop, router)
        line = router.stdout.readline()
        assert line.startswith("router listening on "), (tmp_path / f"router{tag}.log").read_text()
        return router, line.removeprefix("router listening on ").split(",")[0].strip()

    with ExitStack() as stack:
        router, router_endpoint = start_router("", ANY_PORT_ENDPOINT)  # restarted below on the port it got
        client = ZenohSettings(mode="client", connect=(router_endpoint,))
        daemon = _running_daemon(stack, client, {v: ANY_UDP for v in ROSTER})
        _, ports = daemon_ports(daemon)
        mavlink = ports["uav1"]
        _vehicle(stack, tmp_path, None, f"udpout:127.0.0.1:{mavlink}",
                 ["--zenoh-mode", "client", "--zenoh-connect", router_endpoint], time.time() + 2.0)
        wait_for(lambda: _planned_for(daemon, ROSTER) >= 3, 90, "plans through the router")

        router.kill()
        router.wait()
        wait_for(lambda: not any(e.token for e in daemon.registry.entries.values()), 15, "the tokens to go")
        reports_during = daemon.ingest.counters["accepted.report"]
        start_router("-restarted", router_endpoint)
        wait_for(lambda: all(e.token for e in daemon.registry.entries.values()), 30, "the tokens to come back")
        wait_for(lambda: daemon.ingest.counters["accepted.report"] >= reports_during + 30, 60,
                 "reports to flow again")
        plans_after = len(daemon.plans)
        wait_for(lambda: _planned_for(daemon, ROSTER, plans_after) >= 3, 60, "planning to go on")
        status = daemon.status(time.monotonic())
    assert [v.link for v in status.vehicles] == ["ok", "ok", "ok"]
    assert not any(name.startswith("errors.") for name in status.counters), status.counters


def test_a_killed_recorder_leaves_a_recoverable_file(tmp_path) -> None:
    output = tmp_path / "killed.mcap"
    with ExitStack() as stack, open_session(ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=())) as session:
        (endpoint,) = listening_endpoints(session)
        log = stack.enter_context(open(tmp_path / "record.log", "w"))
        recorder = subprocess.Popen([script("gcs"), "record", "-o", str(output), "--zenoh-connect", endpoint],
                                    stdout=subprocess.DEVNULL, stderr=log)
        stack.callback(stop, recorder)
        publisher = declare_publisher(session, report_key("uav1"), SensorReport)
        wait_for(lambda: publisher.matching_status.matching, 30, "the recorder to subscribe")
        seq = 0
        deadline = time.monotonic() + 60
        while not (output.exists() and output.stat().st_size > 200_000):  # a few chunks on disk
            assert time.monotonic() < deadline, "the recording did not grow"
            for _ in range(200):
                seq += 1
                publish(publisher, SensorReport(vehicle_id="uav1", seq=seq, stamp_ns=seq * 1_000_000, vehicle_position_enu_m=(float(seq), 0.0, 100.0)))
            time.sleep(0.01)
        recorder.kill()
        assert recorder.wait(timeout=10) == -signal.SIGKILL
        publisher.undeclare()
    warnings: list[str] = []
    recovered = [r for r in read_recording(output, warn=warnings.append) if r.key == report_key("uav1")]
    assert warnings and "recovered" in warnings[0]  # the file was never finished: said, not hidden
    assert len(recovered) >= 500
    assert [r.publish_time_ns for r in recovered] == [k * 1_000_000 for k in range(1, len(recovered) + 1)]
    info = subprocess.run([script("gcs"), "replay", str(output), "--info", "--json"], capture_output=True, text=True,
                          timeout=60)
    assert info.returncode == 0, info.stderr
    assert json.loads(info.stdout)["messages"] >= len(recovered)
