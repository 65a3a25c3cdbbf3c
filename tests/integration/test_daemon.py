"""The daemon in a thread against simulated vehicles on loopback: queries, bad input, a vehicle lost and back."""

from __future__ import annotations

import threading
import time
from contextlib import ExitStack

import zenoh

from gcs.engine.tracker_factory import horizon_steps, scenario_planner
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES
from gcs.adapters.zenoh_session import ZenohSettings, open_session, query
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.daemon.cli import query_status
from protocols.codec import decode, encode
from protocols.keys import report_key, track_key
from protocols.messages import SensorReport, TrackEstimate
from tests.integration.sim_harness import SCENARIO, WORLD, options, running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT, ANY_UDP, daemon_ports

RATE = 5.0
EPOCH_NS = 1_000_000_000_000


def test_daemon_tracks_answers_rejects_bad_input_and_replans_around_a_lost_vehicle() -> None:
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(listen=(ANY_PORT_ENDPOINT,), connect=()),
                                                   mavlink={v.id: ANY_UDP for v in SCENARIO.vehicles}))
    daemon.open()  # the ports the system chose are known from here on
    endpoint, port = daemon_ports(daemon)
    thread = threading.Thread(target=daemon.run, name="daemon", daemon=True)
    thread.start()
    vehicles = ZenohSettings(connect=(endpoint,))
    try:
        with ExitStack() as stack:
            pair = stack.enter_context(running_vehicles(options(
                port, rate=RATE, zenoh=vehicles, epoch_ns=EPOCH_NS, only=("uav1", "uav2"), wait_for_subscriber_s=5)))
            third = ExitStack()
            third.enter_context(running_vehicles(options(
                port, rate=RATE, zenoh=vehicles, epoch_ns=EPOCH_NS, only=("uav3",), wait_for_subscriber_s=5)))
            wait_until(lambda: len(daemon.records) >= 20, 60, "20 decision steps")
            assert {r.vehicles for r in daemon.records[-5:]} == {("uav1", "uav2", "uav3")}
            assert all(pair.autopilots[v].mode == ARDUPLANE_MODES["GUIDED"] for v in ("uav1", "uav2"))

            session = stack.enter_context(open_session(ZenohSettings(connect=(endpoint,))))
            (sample,) = query(session, track_key("target"), 5.0)
            track = decode(sample.payload.to_bytes(), str(sample.encoding), TrackEstimate)
            assert track.model == "cv2d" and len(track.prediction) == horizon_steps(SCENARIO, scenario_planner(SCENARIO))
            bad = [(report_key("uav1"), b"\xff\xfe not json", "application/json;gcs.SensorReport/1"),
                   (report_key("intruder"), *encode(SensorReport(
                       vehicle_id="intruder", seq=1, stamp_ns=EPOCH_NS, vehicle_position_enu_m=(0.0, 0.0, 100.0)))),
                   (report_key("uav2"), b"{}", "text/plain")]
            for key, payload, encoding in bad:
                session.put(key, payload, encoding=zenoh.Encoding(encoding))
            wait_until(lambda: daemon.ingest.counters["rejected.malformed"] >= 1
                  and daemon.ingest.counters["rejected.unknown_vehicle"] >= 1
                  and daemon.ingest.counters["rejected.encoding"] >= 1, 60, "the bad input to be counted")

            third.close()  # uav3 goes away: liveliness withdrawn, heartbeats stop
            wait_until(lambda: daemon.records[-1].vehicles == ("uav1", "uav2"), 60, "a plan without uav3")
            wait_until(lambda: daemon.registry.link_state("uav3", time.monotonic()) == "lost", 60, "uav3 lost")
            decisions = daemon.counters["decisions"]
            wait_until(lambda: daemon.counters["decisions"] >= decisions + 5, 60, "planning to go on with two")

            resume = (pair.scene.stamp_ns // 1_000_000_000 + 2) * 1_000_000_000
            stack.enter_context(running_vehicles(options(
                port, rate=RATE, zenoh=vehicles, epoch_ns=resume, only=("uav3",), wait_for_subscriber_s=5)))
            wait_until(lambda: daemon.records[-1].vehicles == ("uav1", "uav2", "uav3"), 60, "uav3 re-admitted")
            status = query_status(ZenohSettings(connect=(endpoint,)), "gcs", 5.0)
    finally:
        daemon.stop()
        thread.join(timeout=15)
    assert not thread.is_alive()
    assert status is not None and [v.link for v in status.vehicles] == ["ok", "ok", "ok"]
    assert status.counters["rejected.malformed"] >= 1 and status.counters["rejected.unknown_vehicle"] >= 1
    assert status.counters.get("errors.decision", 0) == 0
    seen = sum(any(r.seen.values()) for r in daemon.records)
    assert seen >= 0.8 * len(daemon.records)
