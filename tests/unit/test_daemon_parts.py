"""The daemon's parts without sockets: ingest validation, decision-step assembly, the vehicle registry."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.adapters.zenoh_io import Received
from gcs.engine.ingest import Ingest
from gcs.engine.registry import LOST_AFTER_S, Registry
from gcs.engine.steps import StepAssembler
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import nav_key, report_key, truth_key
from protocols.messages import Measurement, NavReport, SensorReport, TargetTruth

SCENARIO = load_scenario("wang2012_urban")
S = 1_000_000_000


def _report(vehicle: str = "uav1", stamp: int = 10 * S, seq: int = 1, detected: bool = True) -> SensorReport:
    values = dict(range_m=300.0, range_std_m=10.0, azimuth_rad=0.5, azimuth_std_rad=0.05, elevation_rad=-0.6,
                  elevation_std_rad=0.05) if detected else {}
    return SensorReport(vehicle_id=vehicle, seq=seq, stamp_ns=stamp, vehicle_position_enu_m=(100.0, 200.0, 200.0),
                        detections=(Measurement(**values),) if detected else ())


def _received(key: str, message=None, payload: bytes | None = None, encoding: str | None = None) -> Received:
    if message is not None:
        payload, encoding = encode(message)
    return Received("sample", key, payload, encoding, 0)


def _ingest() -> Ingest:
    return Ingest({v.id for v in SCENARIO.vehicles})


def test_good_messages_are_accepted_and_counted() -> None:
    ingest = _ingest()
    report = _report()
    assert ingest.accept(_received(report_key("uav1"), report)) == report
    nav = NavReport(vehicle_id="uav2", seq=1, stamp_ns=S, velocity_enu_mps=(1.0, 2.0, 0.0))
    assert ingest.accept(_received(nav_key("uav2"), nav)) == nav
    truth = TargetTruth(target_id="target", seq=1, stamp_ns=S, position_enu_m=(1.0, 2.0), velocity_enu_mps=(0.0, 0.0))
    assert ingest.accept(_received(truth_key("target"), truth)) == truth
    assert ingest.counters == {"accepted.report": 1, "accepted.nav": 1, "accepted.truth": 1}


@pytest.mark.parametrize(("key", "payload", "encoding", "reason"), [
    ("gcs/vehicle/uav1/report", b"{not json", "application/json;gcs.SensorReport/1", "malformed"),
    ("gcs/vehicle/uav1/report", b"{}", "application/json;gcs.SensorReport/9", "encoding"),
    ("gcs/vehicle/uav1/report", b"{}", "application/json;gcs.NavReport/1", "unexpected_type"),
    ("gcs/vehicle/uav 1/report", b"{}", "application/json;gcs.SensorReport/1", "key"),
    ("gcs/plan/uav1", b"{}", "application/json;gcs.PlanCommand/1", "unexpected_kind"),
    ("gcs/vehicle/uav1/report", b'{"vehicle_id":"uav1","seq":1,"stamp_ns":1,"vehicle_position_enu_m":[NaN,0,0],'
                                b'"detected":false}', "application/json;gcs.SensorReport/1", "malformed"),
])
def test_bad_input_is_rejected_by_reason(key: str, payload: bytes, encoding: str, reason: str) -> None:
    ingest = _ingest()
    assert ingest.accept(_received(key, payload=payload, encoding=encoding)) is None
    assert ingest.counters == {f"rejected.{reason}": 1}


def test_unknown_vehicles_mismatched_ids_duplicates_and_stale_stamps_are_rejected() -> None:
    ingest = _ingest()
    assert ingest.accept(_received(report_key("intruder"), _report("intruder"))) is None
    assert ingest.accept(_received(report_key("uav2"), _report("uav1"))) is None
    assert ingest.accept(_received(report_key("uav1"), _report(stamp=50 * S))) is not None
    assert ingest.accept(_received(report_key("uav1"), _report(stamp=50 * S, seq=2))) is None  # duplicate stamp
    assert ingest.accept(_received(report_key("uav1"), _report(stamp=49 * S, seq=3))) is not None  # in the window
    assert ingest.accept(_received(report_key("uav1"), _report(stamp=39 * S, seq=4))) is None  # 11 s old: stale
    assert ingest.accept(_received(report_key("uav1"), _report(stamp=51 * S, seq=1))) is not None  # seq restarted
    assert ingest.counters == {"rejected.unknown_vehicle": 1, "rejected.id_mismatch": 1, "rejected.duplicate": 1,
                               "rejected.stale": 1, "accepted.report": 3}


@given(st.binary(max_size=300), st.text(max_size=60))
def test_arbitrary_bytes_never_raise(payload: bytes, encoding: str) -> None:
    ingest = _ingest()
    assert ingest.accept(_received(report_key("uav3"), payload=payload, encoding=encoding)) is None
    assert sum(ingest.counters.values()) == 1 and next(iter(ingest.counters)).startswith("rejected.")


def test_steps_release_when_every_expected_vehicle_has_reported() -> None:
    steps = StepAssembler(step_ns=S, max_wait_s=0.5)
    expected = {"uav1", "uav2"}
    steps.add(_report("uav1", 100 * S), now_s=0.0)
    assert steps.ready(expected, now_s=0.1) == []
    steps.add(_report("uav2", 100 * S), now_s=0.1)
    assert steps.ready(expected, now_s=0.1) == []  # the first step always waits: an earlier stamp may come
    (first,) = steps.ready(expected, now_s=0.5)
    assert first.index == 0 and first.stamp_ns == 100 * S and len(first.reports) == 2
    steps.add(_report("uav1", 101 * S + S // 10), now_s=0.2)  # 0.1 s off the grid: still step 1
    steps.add(_report("uav2", 102 * S), now_s=0.2)  # uav2's step 1 may still come (reorder window)
    assert steps.ready(expected, now_s=0.2) == []
    steps.add(_report("uav2", 103 * S), now_s=0.3)  # two steps on: uav2 skipped step 1
    released = steps.ready(expected, now_s=0.3)
    assert [r.index for r in released] == [1]  # step 2 waits for uav1
    assert released[0].stamp_ns == 101 * S


def _waits_for_nothing(steps: StepAssembler, index: int, expected: set[str]) -> bool:
    """The module docstring's "complete", vehicle by vehicle (the reference for ``StepAssembler._complete``)."""
    if index != steps._next:
        return False
    stamp = steps.stamp_of(index)
    for vehicle in expected:
        if steps._latest_step.get(vehicle, -(2**62)) > index + steps.reorder_steps:
            continue  # it reported past the window: not waited for
        nav = steps._latest_nav_ns.get(vehicle)
        sends_nav = nav is not None and nav > stamp - steps.step_ns
        if vehicle not in steps._arrived_s[index] or (sends_nav and nav < stamp):
            return False
    return True


@settings(max_examples=300)
@given(st.lists(st.tuples(st.sampled_from(["report", "nav"]), st.sampled_from(["uav1", "uav2", "uav3"]),
                          st.integers(0, 3), st.integers(-1, 1)), max_size=20),
       st.sets(st.sampled_from(["uav1", "uav2", "uav3"])))
def test_a_step_is_complete_exactly_when_no_expected_vehicle_is_waited_for(events, expected) -> None:
    steps = StepAssembler(step_ns=S, max_wait_s=0.5)
    steps.add(_report("uav1", 100 * S), now_s=0.0)
    steps.ready(set(), now_s=1.0)  # step 0 out: step 1 is next
    for kind, vehicle, step, offset in events:
        stamp = 100 * S + step * S + offset * (S // 4)
        if kind == "nav":
            steps.add_nav(vehicle, stamp)
        else:
            steps.add(_report(vehicle, stamp), now_s=1.0)
    for index in list(steps._open):
        assert steps._complete(index, expected) == _waits_for_nothing(steps, index, expected)


def test_steps_time_out_in_order_and_late_reports_are_counted() -> None:
    steps = StepAssembler(step_ns=S, max_wait_s=0.5)
    steps.add(_report("uav1", 0), now_s=0.0)
    steps.add(_report("uav1", 1 * S), now_s=0.3)
    assert steps.ready({"uav1", "uav2"}, now_s=0.4) == []
    assert [r.index for r in steps.ready({"uav1", "uav2"}, now_s=0.6)] == [0]
    assert [r.index for r in steps.ready({"uav1", "uav2"}, now_s=0.9)] == [1]
    assert steps.counters["steps_released_by_timeout"] == 2
    assert not steps.add(_report("uav2", 0), now_s=1.0)
    assert steps.counters["rejected.late"] == 1


def test_a_report_from_a_clock_gone_wrong_is_rejected_and_the_vehicle_keeps_its_place() -> None:
    ingest = _ingest()
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 100 * S))) is not None
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 10_000 * S))) is None  # hours ahead
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 100 * S, seq=2))) is not None
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 150 * S, seq=3))) is not None  # within
    assert ingest.counters["rejected.future"] == 1 and ingest.counters["accepted.report"] == 3


def _registry(ages: dict[str, float | None]) -> Registry:
    return Registry(list(SCENARIO.vehicles), lambda vehicle, now: ages.get(vehicle))


def test_alive_from_liveliness_or_heartbeat_and_plannable_needs_navigation() -> None:
    ages = {"uav1": 1.0, "uav2": LOST_AFTER_S + 0.1, "uav3": None}
    registry = _registry(ages)
    assert [registry.alive(v, 0.0) for v in registry.ids] == [True, False, False]
    registry.on_liveliness("uav3", True, 0.0)
    assert registry.alive("uav3", 0.0) and registry.link_state("uav3", 0.0) == "ok"
    assert registry.link_state("uav2", 0.0) == "unknown"
    assert registry.plannable(0.0) == []
    registry.on_report(_report("uav3", 3 * S))
    assert registry.plannable(0.0) == []  # no heading yet
    registry.on_nav(NavReport(vehicle_id="uav3", seq=1, stamp_ns=3 * S, velocity_enu_mps=(0.0, 20.0, 0.0)))
    assert registry.plannable(0.0) == ["uav3"]
    assert registry.entries["uav3"].heading_rad == pytest.approx(math.pi / 2)
    registry.on_liveliness("uav3", False, 1.0)
    assert registry.plannable(1.0) == [] and registry.link_state("uav3", 1.0) == "lost"


def test_position_is_moved_on_with_the_velocity_to_the_step_stamp() -> None:
    registry = _registry({})
    registry.on_report(_report("uav1", 10 * S))
    registry.on_nav(NavReport(vehicle_id="uav1", seq=1, stamp_ns=10 * S, velocity_enu_mps=(3.0, -4.0, 0.0)))
    assert registry.position_at("uav1", 12 * S) == pytest.approx(np.array([106.0, 192.0, 200.0]))
    assert registry.position_at("uav1", 10 * S) == pytest.approx(np.array([100.0, 200.0, 200.0]))


def test_a_snapshot_keeps_what_was_known_when_it_was_taken() -> None:
    registry = _registry({})
    registry.on_report(_report("uav1", 10 * S))
    registry.on_nav(NavReport(vehicle_id="uav1", seq=1, stamp_ns=10 * S, velocity_enu_mps=(3.0, -4.0, 0.0)))
    snapshot = registry.snapshot(["uav1"])
    then = registry.vehicle_state(["uav1"], 12 * S)
    registry.on_report(msgspec.structs.replace(_report("uav1", 11 * S), vehicle_position_enu_m=(500.0, 500.0, 200.0)))
    registry.on_nav(NavReport(vehicle_id="uav1", seq=2, stamp_ns=11 * S, velocity_enu_mps=(0.0, 10.0, 0.0)))
    later = snapshot.at(12 * S)
    for field in ("xy", "heading", "speed", "altitude"):
        np.testing.assert_array_equal(getattr(later, field), getattr(then, field))
    np.testing.assert_allclose(later.xy, [[106.0, 192.0]])
    assert registry.vehicle_state(["uav1"], 12 * S).xy.tolist() == [[500.0, 510.0]]


def test_estimates_that_are_not_finite_or_positive_definite_are_refused() -> None:
    from gcs.core.filters.uif import GaussianEstimate
    from gcs.engine.fusion import FusionDiverged, check_estimate

    check_estimate(None)
    check_estimate(GaussianEstimate(np.zeros(4), np.eye(4), 0))
    for mean, cov in [(np.array([np.nan, 0, 0, 0]), np.eye(4)), (np.zeros(4), np.diag([1.0, -1.0, 1.0, 1.0])),
                      (np.zeros(4), np.diag([1e13, 1.0, 1.0, 1.0])), (np.zeros(4), np.full((4, 4), np.inf))]:
        with pytest.raises(FusionDiverged):
            check_estimate(GaussianEstimate(mean, cov, 0))


def test_absurd_but_valid_reports_are_implausible() -> None:
    ingest = _ingest()
    far = SensorReport(vehicle_id="uav1", seq=1, stamp_ns=S, vehicle_position_enu_m=(5e7, 0.0, 200.0))
    assert ingest.accept(_received(report_key("uav1"), far)) is None
    long_range = _report(stamp=2 * S)
    long_range = msgspec.structs.replace(long_range, detections=(
        long_range.detections[0], msgspec.structs.replace(long_range.detections[0], range_m=5e7)))
    assert ingest.accept(_received(report_key("uav1"), long_range)) is None
    assert ingest.counters == {"rejected.implausible": 2}


def test_a_vehicle_whose_reports_are_refused_for_their_stamps_is_not_waited_for_until_one_is_taken() -> None:
    ingest = _ingest()
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 100 * S))) is not None
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 500 * S))) is None  # minutes ahead
    assert ingest.off_clock == set()  # one stray sample (a spoofed or replayed one) says little
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 501 * S, seq=2))) is None
    assert ingest.off_clock == {"uav2"}  # two in a row: its clock has gone wrong
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 80 * S, seq=2))) is None  # stale
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 81 * S, seq=3))) is None
    assert ingest.off_clock == {"uav1", "uav2"}
    assert ingest.accept(_received(report_key("uav2"), _report("uav2", 101 * S, seq=3))) is not None
    assert ingest.off_clock == {"uav1"}
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 100 * S, seq=4))) is None  # a duplicate
    assert ingest.off_clock == {"uav1"}  # says nothing about its clock
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 102 * S, seq=5))) is not None
    assert ingest.accept(_received(report_key("uav1"), _report("uav1", 500 * S, seq=6))) is None
    assert ingest.off_clock == set()  # the count starts again after an accepted report


def test_plan_commands_carry_the_heading_after_the_step_the_first_turn_rate_and_the_path() -> None:
    from gcs.core.geometry import wrap_angle
    from gcs.core.kinematics import VehicleState, rollout
    from gcs.engine.fusion import plan_commands

    configs = list(SCENARIO.vehicles)
    n = len(configs)
    vehicles = VehicleState(np.array([[100.0 * i, 50.0] for i in range(n)]), np.array([3.1, -3.1, 0.5][:n]),
                            np.full(n, 25.0), np.full(n, 200.0))
    controls = np.array([[0.2, 0.1, 0.0, 0.0, 0.0], [-0.2, 0.0, 0.0, 0.0, 0.0], [0.05, 0.05, 0.05, 0.05, 0.05]][:n])
    limits = np.full(n, 0.3)
    commands = plan_commands(vehicles, configs, controls, limits, 1.0, 1234, 7, "ga_k5")
    path, _ = rollout(vehicles, controls, 1.0, limits)
    for slot, (command, cfg) in enumerate(zip(commands, configs)):
        assert (command.vehicle_id, command.seq, command.stamp_ns, command.planner) == (cfg.id, 7 + slot, 1234, "ga_k5")
        assert command.turn_rate_rad_s == controls[slot, 0]
        assert command.heading_rad == wrap_angle(float(vehicles.heading[slot] + controls[slot, 0]))
        assert -math.pi < command.heading_rad <= math.pi
        np.testing.assert_array_equal(np.array(command.planned_path_enu_m), path[slot])
        assert (command.airspeed_mps, command.altitude_m) == (cfg.speed_mps, cfg.altitude_m)
        encode(command)
