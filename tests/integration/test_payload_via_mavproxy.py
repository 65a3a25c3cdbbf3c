"""The payload bridge behind a real MAVProxy: our own ArduPlane personalities as the autopilots, on 127.0.0.1.

The simulated vehicles (``arduplane`` personality, 1 Hz telemetry until asked, real
time) send to MAVProxy's master port and publish nothing over Zenoh, so every report
the test's subscriber sees is the bridge's. The bridge reads MAVProxy's ``--out`` for
uav1 and uav2 (one socket, demultiplexed by sysid; uav3's telemetry is ignored) and
asks for 5 Hz telemetry; MAVProxy asks for none (``--streamrate=-1``), so the stream
rate the vehicles end up with is the bridge's request.

The figures to compare with are the simulator's own: its vehicles' true positions,
sampled on the wall clock as they fly (the simulator's GLOBAL_POSITION_INT is its
truth), and its GPS receiver's accuracy.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path

import msgspec
import numpy as np
import zenoh

from gcs.adapters.mavlink_wire import mavlink
from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.config.fingerprint import scenario_fingerprint
from protocols.codec import decode
from protocols.keys import (alive_key, alive_selector, navs_selector, parse_key, reports_selector, scenarios_selector,
                            truth_selector)
from protocols.messages import NavReport, SensorReport, TargetTruth, VehicleScenario
from sim_vehicles.payload import PayloadBridge
from sim_vehicles.payload_command import PayloadOptions, PayloadRunner
from tests.integration.mavproxy_harness import MavProxy
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, LOCALHOST

ARDUPLANE = msgspec.structs.replace(SCENARIO, simulation=msgspec.structs.replace(SCENARIO.simulation,
                                                                                  autopilot="arduplane"))
BRIDGED = ("uav1", "uav2")
REQUEST_HZ = 5.0
STALE_AFTER_S = 1.0
POSITION_TOLERANCE_M = 5.0
"""Between a report's position and the truth at its stamp. The bridge moves the last GLOBAL_POSITION_INT (at most
0.2 s old at 5 Hz) to the stamp by its velocity, so what is left is the curvature of the loiter over that time
(centimetres) and how the simulator's truth maps to the wall clock: it runs up to a physics step (50 ms, 1.25 m
at 25 m/s) ahead of it; 0.2-1.3 m measured. 5 m allows more delay on a loaded machine and still catches a frame,
axis or unit error (hundreds of metres) or a stamp a step of the simulator's 1 Hz telemetry (25 m) off."""
WAIT_S = 30.0


def wait_until(condition: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


class TruthSampler:
    """The simulated vehicles' true positions on the wall clock (ns), sampled every 20 ms on a thread."""

    def __init__(self, runner) -> None:
        self.runner, self.samples = runner, {vid: [] for vid in BRIDGED}
        self.stamps: list[int] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.02):
            positions = {vid: np.array(self.runner.scene.vehicles[vid].state.position_enu_m) for vid in BRIDGED}
            self.stamps.append(time.time_ns())
            for vid in BRIDGED:
                self.samples[vid].append(positions[vid])

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)

    def at(self, vehicle_id: str, stamp_ns: int) -> np.ndarray | None:
        """The true position at ``stamp_ns`` (linear between samples), None outside the sampled span."""
        stamps = np.array(self.stamps, dtype=np.int64)
        if len(stamps) < 2 or not stamps[0] <= stamp_ns <= stamps[-1]:
            return None
        track = np.array(self.samples[vehicle_id])
        return np.array([np.interp(stamp_ns, stamps, track[:, k]) for k in range(3)])


def test_bridge_behind_mavproxy_publishes_the_vehicles_reports_where_they_fly(tmp_path: Path) -> None:
    received: queue.Queue = queue.Queue()
    alive: queue.Queue = queue.Queue()
    with open_session(ZenohSettings(mode="peer", listen=(ANY_PORT_ENDPOINT,), connect=())) as session:
        (endpoint,) = listening_endpoints(session)
        for selector in (reports_selector(), navs_selector(), truth_selector(), scenarios_selector()):
            session.declare_subscriber(selector, lambda s: received.put(
                (str(s.key_expr), s.payload.to_bytes(), str(s.encoding), time.time_ns())))
        session.liveliness().declare_subscriber(alive_selector(), lambda s: alive.put((str(s.key_expr), s.kind)),
                                                history=True)
        bridge = PayloadBridge(ARDUPLANE, WORLD, list(BRIDGED), seed=5, stale_after_s=STALE_AFTER_S)
        runner = PayloadRunner(bridge, PayloadOptions({vid: ANY_UDP for vid in BRIDGED},
                                                      ZenohSettings(mode="peer", connect=(endpoint,)),
                                                      request_rate_hz=REQUEST_HZ))
        thread = threading.Thread(target=runner.run, name="payload-bridge", daemon=True)
        thread.start()
        try:
            assert runner.opened.wait(10), "the bridge did not open its links"
            bridge_port = runner.links[ANY_UDP].port.getsockname()[1]
            messages, events = [], []
            with MavProxy(outs=[f"udpout:{LOCALHOST}:{bridge_port}"], extra_args=["--streamrate=-1"],
                          workdir=tmp_path / "mavproxy") as proxy, \
                    running_vehicles(options(proxy.master_port, rate=1.0, seed=5), ARDUPLANE) as sim:
                truth = TruthSampler(sim)

                def enough() -> bool:
                    while not received.empty():
                        messages.append(received.get())
                    kinds = [parse_key(m[0]) for m in messages]
                    return all(sum(k.kind == "nav" and k.ident == v for k in kinds) >= 15
                               and sum(k.kind == "report" and k.ident == v for k in kinds) >= 3 for v in BRIDGED)

                wait_until(enough, WAIT_S, "15 nav reports and 3 sensor reports of each bridged vehicle")
                rates = {vid: sim.autopilots[vid].schedule.rate_hz(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT)
                         for vid in ("uav1", "uav2", "uav3")}
                gps = {vid: sim.scene.vehicles[vid].gps for vid in BRIDGED}
                satellites = ARDUPLANE.simulation.gps.satellites
                truth.stop()
            # The vehicles are gone: the bridge withdraws their liveliness once telemetry is STALE_AFTER_S old.
            wait_until(lambda: (events.extend(iter_queue(alive)) or True) and {
                k for k, kind in events if kind == zenoh.SampleKind.DELETE} >= {alive_key(v) for v in BRIDGED},
                10.0, "the liveliness withdrawn after the telemetry stopped")
        finally:
            runner.stop()
            thread.join(10)
        assert not thread.is_alive(), "the bridge did not stop"

    declared = [k for k, kind in events if kind == zenoh.SampleKind.PUT]
    assert sorted(set(declared)) == sorted(alive_key(v) for v in BRIDGED)
    assert rates == {"uav1": REQUEST_HZ, "uav2": REQUEST_HZ, "uav3": 1.0}  # asked for by the bridge only
    assert runner.counters["other_systems"] > 0  # uav3 and MAVProxy's own heartbeats, ignored
    frame = bridge.scene.frame
    navs: dict[str, list] = {v: [] for v in BRIDGED}
    reports: dict[str, list] = {v: [] for v in BRIDGED}
    truths: dict[int, TargetTruth] = {}
    announced: dict[str, list[int]] = {v: [] for v in BRIDGED}
    for key, payload, encoding, received_ns in messages:
        parsed = parse_key(key)
        if parsed.kind == "scenario":  # the bridged vehicles fly against the scenario: they say which
            message = decode(payload, encoding, VehicleScenario)
            assert (message.vehicle_id, message.scenario, message.fingerprint) == (
                parsed.ident, ARDUPLANE.name, scenario_fingerprint(ARDUPLANE))
            announced[parsed.ident].append(message.stamp_ns)
            continue
        if parsed.kind == "truth":
            message = decode(payload, encoding, TargetTruth)
            truths[message.stamp_ns] = message
            continue
        message = decode(payload, encoding, NavReport if parsed.kind == "nav" else SensorReport)
        assert parsed.ident in BRIDGED and message.vehicle_id == parsed.ident
        assert -0.05e9 < received_ns - message.stamp_ns < 1e9  # stamped on the bridge's wall clock
        (navs if parsed.kind == "nav" else reports)[parsed.ident].append(message)

    for vid in BRIDGED:
        checked = 0
        # A nav report may go out before the first GPS_RAW_INT (1 Hz until the bridge's request is served): it then
        # carries no fix. From the first fix on, every one has it.
        first_fix = next(i for i, nav in enumerate(navs[vid]) if nav.gps is not None)
        assert navs[vid][first_fix].stamp_ns - navs[vid][0].stamp_ns <= 1_200_000_000  # within a GPS_RAW_INT period
        for nav in navs[vid][first_fix:]:
            assert nav.gps is not None and nav.gps.fix_type == 3 and nav.gps.satellites == satellites
            assert abs(nav.gps.h_acc_m - gps[vid].horizontal_std_m) <= 1e-3  # GPS_RAW_INT.h_acc, mm
            position = frame.to_enu(nav.gps.lat_deg, nav.gps.lon_deg, nav.gps.alt_m)
            true = truth.at(vid, nav.stamp_ns)
            if true is None:
                continue
            checked += 1
            error = math.hypot(position[0] - true[0], position[1] - true[1])
            assert error < POSITION_TOLERANCE_M, f"{vid} nav {error:.1f} m from the truth"
            assert abs(nav.gps.alt_m - frame.height_m - true[2]) < 1.0
            speed = math.hypot(*nav.velocity_enu_mps[:2])
            assert abs(speed - ARDUPLANE.vehicles[0].speed_mps) < 2.0
        assert checked >= 10, f"{vid}: {checked} nav reports inside the sampled truth"
        stamps = [r.stamp_ns for r in reports[vid]]
        assert all(b - a == 1_000_000_000 for a, b in zip(stamps, stamps[1:]))  # report_rate_hz 1
        # announced with each report (1 Hz), stamped alike; the collection may end between the two of a pair
        common = min(len(announced[vid]), len(stamps))
        assert common >= 3 and announced[vid][:common] == stamps[:common]
        assert abs(len(announced[vid]) - len(stamps)) <= 1
        for report in reports[vid]:
            true = truth.at(vid, report.stamp_ns)
            assert report.vehicle_position_std_m == nav.gps.h_acc_m
            assert report.stamp_ns in truths  # the target's truth at each report
            if true is None:
                continue
            assert np.linalg.norm(np.array(report.vehicle_position_enu_m[:2]) - true[:2]) < POSITION_TOLERANCE_M
            if report.detected:
                target = np.array([*truths[report.stamp_ns].position_enu_m, 0.0])
                (detection,) = report.detections
                assert abs(detection.range_m - np.linalg.norm(target - true)) < 5 * 10.0 + POSITION_TOLERANCE_M
    assert bridge.counts["uav1"]["bad_telemetry"] == 0 and bridge.counts["uav1"]["withdrawn"] == 1


def iter_queue(q: queue.Queue):
    """Everything waiting in ``q`` now."""
    while True:
        try:
            yield q.get_nowait()
        except queue.Empty:
            return
