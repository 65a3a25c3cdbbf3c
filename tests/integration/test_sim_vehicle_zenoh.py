"""Simulated vehicles publish SensorReport and NavReport over Zenoh, with liveliness, on loopback."""

from __future__ import annotations

import queue
import time

import zenoh

from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.config.fingerprint import scenario_fingerprint
from protocols.codec import decode
from protocols.keys import (alive_key, alive_selector, navs_selector, parse_key, report_key, reports_selector,
                           truth_selector)
from protocols.messages import NavReport, SensorReport, VehicleScenario
from tests.integration.sim_harness import SCENARIO, running_vehicles
from sim_vehicles.run_options import RunOptions
from tests.loopback import ANY_PORT_ENDPOINT

RATE = 20.0
EPOCH_NS = 1_700_000_000_000_000_000


REPORTS = 40
"""Reports of each vehicle to collect: 40 s of simulation, 2 s of wall time at 20x on an idle machine."""


def _collect(samples: queue.Queue, enough, what: str, timeout_s: float = 60.0) -> list:
    """Samples from the queue until ``enough(samples so far)``; AssertionError naming ``what`` after ``timeout_s``."""
    out, deadline = [], time.monotonic() + timeout_s
    while not enough(out):
        assert time.monotonic() < deadline, f"{what}: not within {timeout_s} s ({len(out)} samples)"
        try:
            out.append(samples.get(timeout=0.05))
        except queue.Empty:
            pass
    return out


def test_reports_nav_and_liveliness_in_simulation_time() -> None:
    ids = {v.id for v in SCENARIO.vehicles}
    samples: queue.Queue = queue.Queue()
    alive: queue.Queue = queue.Queue()
    with open_session(ZenohSettings(mode="peer", listen=(ANY_PORT_ENDPOINT,), connect=())) as session:
        (endpoint,) = listening_endpoints(session)  # the vehicles connect where the system let it listen
        options = RunOptions(rate=RATE, seed=3, epoch_ns=EPOCH_NS,
                             zenoh=ZenohSettings(mode="peer", connect=(endpoint,)))
        session.declare_subscriber(reports_selector(), lambda s: samples.put((str(s.key_expr), s.payload.to_bytes(),
                                                                             str(s.encoding))))
        session.declare_subscriber(navs_selector(), lambda s: samples.put((str(s.key_expr), s.payload.to_bytes(),
                                                                          str(s.encoding))))
        session.liveliness().declare_subscriber(alive_selector(), lambda s: alive.put((str(s.key_expr), s.kind)),
                                                history=True)
        with running_vehicles(options):
            received = _collect(samples, lambda out: all(
                sum(key == report_key(v) for key, _, _ in out) >= REPORTS for v in ids), f"{REPORTS} reports each")
            tokens = {str(reply.ok.key_expr) for reply in session.liveliness().get(alive_selector(), timeout=30.0)
                      if reply.ok is not None}
        departures = _collect(alive, lambda out: {key for key, kind in out if kind == zenoh.SampleKind.DELETE}
                              >= {alive_key(v) for v in ids}, "every token withdrawn")
    assert tokens == {alive_key(v) for v in ids}, tokens
    gone = {key for key, kind in departures if kind == zenoh.SampleKind.DELETE}
    assert gone == tokens, f"liveliness withdrawn for {gone} only"

    reports: dict[str, list[SensorReport]] = {v: [] for v in ids}
    navs: dict[str, list[NavReport]] = {v: [] for v in ids}
    for key, payload, encoding in received:
        parsed = parse_key(key)
        if parsed.kind == "report":
            message = decode(payload, encoding, SensorReport)
            reports[parsed.ident].append(message)
        else:
            message = decode(payload, encoding, NavReport)
            navs[parsed.ident].append(message)
        assert message.vehicle_id == parsed.ident and message.stamp_ns >= EPOCH_NS
    for vehicle in ids:
        stamps = [r.stamp_ns for r in reports[vehicle]]
        assert len(stamps) >= REPORTS, f"{vehicle}: {len(stamps)} reports"
        assert all(b - a == 1_000_000_000 for a, b in zip(stamps, stamps[1:]))  # simulation time, 1 Hz
        assert [r.seq for r in reports[vehicle]] == list(range(reports[vehicle][0].seq, reports[vehicle][0].seq
                                                                + len(stamps)))
        nav_stamps = [n.stamp_ns for n in navs[vehicle]]
        assert all(b - a == 200_000_000 for a, b in zip(nav_stamps, nav_stamps[1:]))  # 5 Hz
        assert all(n.gps is not None and n.gps.fix_type >= 3 for n in navs[vehicle])
        assert all(n.ins is not None and n.ins.dt_s == 0.2 for n in navs[vehicle] if n.stamp_ns > EPOCH_NS)
    detected = [r for rs in reports.values() for r in rs if r.detected]
    assert detected and all(len(r.detections) == 1 and r.detections[0].range_m is not None
                            and r.detections[0].range_std_m == 10.0 for r in detected)
    assert any(r.detections == () for rs in reports.values() for r in rs)


def test_each_vehicle_announces_its_scenario_before_its_reports() -> None:
    """With its first report and then with each report a second of its time later (reports come at 1 Hz): the
    scenario's name and the fingerprint of its settings, stamped as the report it comes before."""
    samples: queue.Queue = queue.Queue()
    order_ids = [v.id for v in SCENARIO.vehicles]
    with open_session(ZenohSettings(mode="peer", listen=(ANY_PORT_ENDPOINT,), connect=())) as session:
        (endpoint,) = listening_endpoints(session)
        options = RunOptions(rate=RATE, seed=3, epoch_ns=EPOCH_NS, duration_s=20.0,
                             zenoh=ZenohSettings(mode="peer", connect=(endpoint,)), wait_for_subscriber_s=30.0)
        session.declare_subscriber("gcs/vehicle/*/*", lambda s: samples.put((str(s.key_expr), s.payload.to_bytes(),
                                                                           str(s.encoding))))  # one: in order
        session.declare_subscriber(truth_selector(), lambda s: None)  # the vehicles start once every key is heard
        with running_vehicles(options) as runner:
            while not runner.stop_event.wait(0.05) and runner.summary.simulated_s < 20.0:
                pass
        received = _collect(samples,
                            lambda got: sum(not key.endswith("/nav") for key, _, _ in got) >= 40 * len(order_ids),
                            "each vehicle's 20 reports and announcements")
    order: dict[str, list[tuple[str, int]]] = {vehicle: [] for vehicle in order_ids}
    for key, payload, encoding in received:
        parsed = parse_key(key)
        if parsed.kind == "nav":
            continue
        message = decode(payload, encoding)
        if parsed.kind == "scenario":
            assert message == VehicleScenario(vehicle_id=parsed.ident, stamp_ns=message.stamp_ns,
                                              scenario="wang2012_urban", fingerprint=scenario_fingerprint(SCENARIO))
        order[parsed.ident].append((parsed.kind, message.stamp_ns))
    for vehicle, seen in order.items():
        assert len(seen) == 40, (vehicle, seen)  # 20 s at 1 Hz: 20 reports, each announced first
        assert seen == [(kind, stamp) for _, stamp in seen[1::2] for kind in ("scenario", "report")], vehicle
