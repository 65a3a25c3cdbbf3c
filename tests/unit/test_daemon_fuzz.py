"""The daemon's whole ingest path, fuzzed: whatever arrives, the loop goes on and counts what it rejects.

A :class:`~gcs.daemon.app.Daemon` runs its real loop (:meth:`Daemon.turn`: ingest,
registry, step assembly, fusion, planning, publication) on a fake Zenoh inbox
fed by Hypothesis: valid reports from roster and unknown vehicles with absurd
but valid values, duplicates, stale, future and out-of-order stamps, random
bytes, NaN in JSON, wrong encodings and keys, liveliness coming and going, the
vehicles' scenario announcements (this scenario's, another's, under another's key).
"""

from __future__ import annotations

import math

import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gcs.adapters.zenoh_io import Received
from gcs.adapters.zenoh_session import ZenohSettings
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.config.world import build_world
from gcs.daemon.plan_runner_start import start_plan_runner
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import nav_key, report_key, scenario_key, truth_key
from protocols.messages import Measurement, NavReport, SensorReport, TargetTruth
from tests.unit.test_protocols_codec import nav_reports, sensor_reports, vehicle_scenarios

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
S = 1_000_000_000
EPOCH_NS = 1_000_000 * S
ROSTER = tuple(v.id for v in SCENARIO.vehicles)
VEHICLE_IDS = st.sampled_from(ROSTER + ("intruder", "uav9"))
STAMPS = st.one_of(st.integers(-5, 40).map(lambda k: EPOCH_NS + k * S),  # on the step grid (duplicates likely)
                   st.integers(EPOCH_NS - 100 * S, EPOCH_NS + 200 * S),  # anywhere near: stale, future
                   st.integers(0, 2**63 - 1))


class FakeZenoh:
    """The daemon's Zenoh port without a session: an inbox the test fills, and what was published."""

    def __init__(self) -> None:
        self.inbox: list[Received] = []
        self.published: list = []

    def drain(self) -> list[Received]:
        out, self.inbox = self.inbox, []
        return out

    def publish_track(self, track) -> None:
        self.published.append(track)

    def publish_plan(self, plan) -> None:
        self.published.append(plan)

    def publish_status(self, status) -> None:
        self.published.append(status)

    def answer_queries(self, status=None) -> int:
        return 0

    def close(self) -> None:
        pass


def _daemon(accept_unlisted: bool = False) -> Daemon:
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(), planner="pursuit", plan_runner="inline",
                                                   accept_unlisted=accept_unlisted))
    daemon.zenoh = FakeZenoh()
    daemon.plan_runner = start_plan_runner("inline", SCENARIO, WORLD, "pursuit", 0, daemon._subset)
    return daemon


def _sample(key: str, message) -> Received:
    payload, encoding = encode(message)
    return Received("sample", key, payload, encoding, 0)


@st.composite
def report_samples(draw) -> Received:
    vehicle = draw(VEHICLE_IDS)
    report = msgspec.structs.replace(draw(sensor_reports()), vehicle_id=vehicle, stamp_ns=draw(STAMPS))
    key_vehicle = vehicle if draw(st.integers(0, 9)) else draw(VEHICLE_IDS)  # sometimes under another's key
    return _sample(report_key(key_vehicle), report)


@st.composite
def nav_samples(draw) -> Received:
    vehicle = draw(VEHICLE_IDS)
    return _sample(nav_key(vehicle), msgspec.structs.replace(draw(nav_reports()), vehicle_id=vehicle,
                                                              stamp_ns=draw(STAMPS)))


@st.composite
def truth_samples(draw) -> Received:
    value = st.floats(-1e6, 1e6)
    return _sample(truth_key("target"), TargetTruth(target_id="target", seq=1, stamp_ns=draw(STAMPS),
                                                    position_enu_m=(draw(value), draw(value)),
                                                    velocity_enu_mps=(0.0, 0.0)))


@st.composite
def scenario_samples(draw) -> Received:
    announced = msgspec.structs.replace(draw(vehicle_scenarios), vehicle_id=draw(VEHICLE_IDS))
    key_vehicle = announced.vehicle_id if draw(st.integers(0, 9)) else draw(VEHICLE_IDS)
    return _sample(scenario_key(key_vehicle), announced)


@st.composite
def plausible_reports(draw) -> Received:
    """Reports a vehicle could send: the target seen about 300 m away, on the step grid."""
    vehicle = draw(st.sampled_from(ROSTER))
    x, y = draw(st.floats(0.0, 3000.0)), draw(st.floats(0.0, 3000.0))
    report = SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=EPOCH_NS + draw(st.integers(0, 40)) * S,
                          vehicle_position_enu_m=(x, y, 200.0), detections=(Measurement(
                              range_m=draw(st.floats(50.0, 800.0)), range_std_m=10.0,
                              azimuth_rad=draw(st.floats(-math.pi, math.pi)), azimuth_std_rad=0.05,
                              elevation_rad=draw(st.floats(-1.5, -0.1)), elevation_std_rad=0.05),))
    return _sample(report_key(vehicle), report)


@st.composite
def plausible_navs(draw) -> Received:
    vehicle = draw(st.sampled_from(ROSTER))
    heading = draw(st.floats(-math.pi, math.pi))
    nav = NavReport(vehicle_id=vehicle, seq=1, stamp_ns=EPOCH_NS + draw(st.integers(0, 40)) * S,
                    velocity_enu_mps=(25.0 * math.cos(heading), 25.0 * math.sin(heading), 0.0), heading_rad=heading)
    return _sample(nav_key(vehicle), nav)


garbage = st.builds(
    lambda key, payload, encoding: Received("sample", key, payload, encoding, 0),
    st.sampled_from([report_key("uav1"), nav_key("uav2"), truth_key("target"), "gcs/plan/uav1", "gcs/vehicle//report",
                     "gcs/vehicle/uav1/unknown", "other/vehicle/uav1/report"]),
    st.one_of(st.binary(max_size=200),
              st.just(b'{"vehicle_id":"uav1","seq":1,"stamp_ns":1,"vehicle_position_enu_m":[NaN,0,0],"detected":false}'),
              st.just(b'{"vehicle_id":"uav1","seq":"one","stamp_ns":1e400}'), st.just(b"[]"), st.just(b"null")),
    st.sampled_from(["application/json;gcs.SensorReport/1", "application/json;gcs.NavReport/1", "text/plain", "",
                     "application/json;gcs.SensorReport/99"]))
liveliness = st.builds(lambda vehicle, up: Received("alive" if up else "gone", f"gcs/vehicle/{vehicle}/alive", b"",
                                                  "", 0),
                       VEHICLE_IDS | st.just("bad id"), st.integers(0, 3).map(bool))
items = st.one_of(report_samples(), nav_samples(), truth_samples(), plausible_reports(), plausible_reports(),
                  plausible_navs(), scenario_samples(), garbage, liveliness)


def _run(daemon: Daemon, batches: list[tuple[float, list[Received]]]) -> None:
    now = 0.0
    for advance, batch in batches:
        now += advance
        daemon.zenoh.inbox.extend(batch)
        daemon.turn(now)
    daemon.turn(now + 10.0)  # every open step times out


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(st.lists(st.tuples(st.floats(0.0, 0.7), st.lists(items, max_size=8)), min_size=1, max_size=12),
       st.booleans())
def test_whatever_arrives_the_daemon_goes_on_and_counts_every_rejection(batches, accept_unlisted) -> None:
    daemon = _daemon(accept_unlisted)
    try:
        _run(daemon, batches)
        status = daemon.status(100.0)
    finally:
        daemon.plan_runner.close()
    samples = sum(1 for _, batch in batches for item in batch if item.kind == "sample" or " " in item.key)
    counters = status.counters
    # accepted first, then dropped (a step whose fusion diverged: its reports were accepted)
    after_ingest = {"rejected.late", "rejected.late_nav", "rejected.nav_update", "rejected.diverged"}
    ingest = sum(v for k, v in counters.items() if k.startswith("accepted.")) + \
        sum(v for k, v in counters.items() if k.startswith("rejected.") and k not in after_ingest)
    assert ingest == samples, counters  # every sample (and bad liveliness key) accepted or rejected by reason
    assert not any(k.startswith("errors.") for k in counters), counters
    if not accept_unlisted:
        assert not any(k.startswith("accepted.unlisted") for k in counters)
    for message in daemon.zenoh.published:
        encode(message)  # everything published is a valid, finite message


def _seen_from(vehicle: str, stamp_ns: int) -> Received:
    tx, ty = SCENARIO.target.start_enu_m
    x, y = tx - 300.0, ty
    ground = math.hypot(tx - x, ty - y)
    report = SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=(x, y, 200.0),
                          detections=(Measurement(range_m=math.hypot(ground, 200.0), range_std_m=10.0, azimuth_rad=0.0,
                                                  azimuth_std_rad=0.05, elevation_rad=-math.atan2(200.0, ground),
                                                  elevation_std_rad=0.05),))
    return _sample(report_key(vehicle), report)


def test_reports_from_outside_the_roster_are_rejected_unless_accepted_on_request() -> None:
    for accept in (False, True):
        daemon = _daemon(accept_unlisted=accept)
        try:
            _run(daemon, [(0.1 * k, [_seen_from("observer1", EPOCH_NS + k * S)]) for k in range(3)])
        finally:
            daemon.plan_runner.close()
        tracks = [m for m in daemon.zenoh.published if type(m).__name__ == "TrackEstimate"]
        counters = daemon.status(0.0).counters
        if accept:
            assert counters["accepted.unlisted.report"] == 3 and "rejected.unknown_vehicle" not in counters
            assert len(tracks) == 3 and all(t.contributing_vehicles == ("observer1",) for t in tracks)
            assert not any(type(m).__name__ == "PlanCommand" for m in daemon.zenoh.published)  # never commanded
        else:
            assert counters["rejected.unknown_vehicle"] == 3 and tracks == []


def test_a_step_whose_fusion_diverges_is_counted_and_the_previous_estimate_stands(monkeypatch) -> None:
    import gcs.core.single_target as single_target
    from gcs.core.filters.uif import NotPositiveDefinite

    daemon = _daemon()
    try:
        _run(daemon, [(0.1, [_seen_from("uav1", EPOCH_NS)])])
        before = daemon.loop.estimate
        assert before is not None

        def diverging(*args, **kwargs):
            raise NotPositiveDefinite("made to fail")

        monkeypatch.setattr(single_target, "fuse", diverging)
        _run(daemon, [(0.1, [_seen_from("uav1", EPOCH_NS + S)])])
    finally:
        daemon.plan_runner.close()
    assert daemon.counters["rejected.diverged"] == 1 and daemon.loop.estimate is before
    assert "errors.decision" not in daemon.counters


def test_a_behind_loop_publishes_each_step_before_handling_the_next_and_plans_the_newest_once() -> None:
    """Three steps' reports in one pass: each step's track is put as soon as its reports are handled
    (not after the whole batch), and only the last step is planned."""
    daemon = _daemon()
    order: list[tuple[str, int]] = []
    handle, publish = daemon._handle, daemon.zenoh.publish_track

    def handled(item, now):
        handle(item, now)
        if item.kind == "sample" and "/report" in item.key:
            order.append(("report", msgspec.json.decode(item.payload)["stamp_ns"]))

    def published(track):
        order.append(("track", track.stamp_ns))
        publish(track)

    daemon._handle, daemon.zenoh.publish_track = handled, published
    alive = [Received("alive", f"gcs/vehicle/{v}/alive", b"", "", 0) for v in ROSTER]
    navs = [_sample(nav_key(v), NavReport(vehicle_id=v, seq=1, stamp_ns=EPOCH_NS, velocity_enu_mps=(25.0, 0.0, 0.0),
                                          heading_rad=0.0)) for v in ROSTER]
    try:
        _run(daemon, [(0.1, alive + navs + [_seen_from(v, EPOCH_NS) for v in ROSTER])])  # step 0 times out
        daemon.turn(10.2)  # its plan (made inline when handed over) is applied
        order.clear()
        plans_before = len(daemon.plans)
        daemon.zenoh.inbox.extend(_seen_from(v, EPOCH_NS + k * S) for k in (1, 2, 3) for v in ROSTER)
        daemon.turn(20.0)
        daemon.turn(20.1)
    finally:
        daemon.plan_runner.close()
    expected = []
    for k in (1, 2, 3):
        expected += [("report", EPOCH_NS + k * S)] * len(ROSTER) + [("track", EPOCH_NS + k * S)]
    assert order == expected
    planned = daemon.plans[plans_before:]
    assert [plan.stamp_ns for plan in planned] == [EPOCH_NS + 3 * S]
    assert daemon.counters["steps_fused_only"] == 2


class _HeldPlanRunner:
    """A planner the test keeps planning or frees; it records the steps handed to it."""

    def __init__(self) -> None:
        self.planning, self.jobs = False, []

    def submit(self, job) -> None:
        self.jobs.append(job.stamp_ns)
        self.planning = True

    def take(self) -> list:
        return []

    def finished(self) -> bool:
        return False

    def close(self) -> None:
        pass


def test_a_plan_interval_grows_with_the_team_from_the_minimum_to_a_steering_period() -> None:
    from gcs.daemon.app import MIN_PLAN_INTERVAL_S, PLAN_INTERVAL_PER_VEHICLE_S, STEER_RATE_HZ, plan_interval_s

    small = int(MIN_PLAN_INTERVAL_S / PLAN_INTERVAL_PER_VEHICLE_S)
    assert [plan_interval_s(n) for n in (0, 1, 3, small)] == [MIN_PLAN_INTERVAL_S] * 4
    assert plan_interval_s(small + 20) == pytest.approx((small + 20) * PLAN_INTERVAL_PER_VEHICLE_S)
    assert MIN_PLAN_INTERVAL_S < plan_interval_s(small + 20) < plan_interval_s(small + 40) <= 1.0 / STEER_RATE_HZ
    assert plan_interval_s(100) == plan_interval_s(10_000) == 1.0 / STEER_RATE_HZ


@pytest.mark.parametrize("per_vehicle_s", [None, 0.05])
def test_the_newest_step_waits_for_a_free_planner_and_plans_are_handed_over_at_most_every_interval(
        per_vehicle_s, monkeypatch) -> None:
    from gcs.daemon import app
    from gcs.engine import memory

    if per_vehicle_s is not None:  # as if the team were large: the interval is that of 3 vehicles at this cost
        monkeypatch.setattr(memory, "PLAN_INTERVAL_PER_VEHICLE_S", per_vehicle_s)
    interval = memory.plan_interval_s(len(ROSTER))
    assert interval == (app.MIN_PLAN_INTERVAL_S if per_vehicle_s is None else 3 * per_vehicle_s)
    daemon = _daemon()
    daemon.plan_runner.close()
    daemon.plan_runner = planner = _HeldPlanRunner()
    alive = [Received("alive", f"gcs/vehicle/{v}/alive", b"", "", 0) for v in ROSTER]
    navs = [_sample(nav_key(v), NavReport(vehicle_id=v, seq=1, stamp_ns=EPOCH_NS, velocity_enu_mps=(25.0, 0.0, 0.0),
                                          heading_rad=0.0)) for v in ROSTER]
    _run(daemon, [(0.1, alive + navs + [_seen_from(v, EPOCH_NS) for v in ROSTER])])  # step 0, handed over at 10.1
    assert planner.jobs == [EPOCH_NS]

    def step(k: int, now: float) -> None:
        daemon.zenoh.inbox.extend(_seen_from(v, EPOCH_NS + k * S) for v in ROSTER)
        daemon.turn(now)

    step(1, 11.0)
    step(2, 11.1)  # the planner is planning: step 2 waits, step 1 is fused only
    assert planner.jobs == [EPOCH_NS] and daemon.counters["steps_fused_only"] == 1
    planner.planning = False
    daemon.turn(11.2)
    assert planner.jobs == [EPOCH_NS, EPOCH_NS + 2 * S]
    planner.planning = False
    step(3, 11.2 + interval * 0.9)  # free, but too soon after the last hand-over
    assert planner.jobs[-1] == EPOCH_NS + 2 * S
    daemon.turn(11.2 + interval)
    assert planner.jobs == [EPOCH_NS, EPOCH_NS + 2 * S, EPOCH_NS + 3 * S]


def test_the_loop_freezes_what_it_keeps_every_second_and_collects_it_all_every_ten_minutes(monkeypatch) -> None:
    import gc

    from gcs.daemon import heap

    calls: list[str] = []
    monkeypatch.setattr(gc, "freeze", lambda: calls.append("freeze"))
    monkeypatch.setattr(gc, "unfreeze", lambda: calls.append("unfreeze"))
    monkeypatch.setattr(gc, "collect", lambda *args: calls.append("collect") or 0)
    ticks = iter(range(100_000))
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(), planner="pursuit", plan_runner="inline"),
                    clock=lambda: 0.25 * next(ticks))  # every reading of the clock (once a pass) 0.25 s on
    daemon.zenoh = FakeZenoh()
    daemon.zenoh.open = lambda: None
    daemon.zenoh.wait = lambda timeout_s, until=None: False
    passes = []
    daemon.run(until=lambda: passes.append(1) or len(passes) > 2800)  # about 700 s of the fake clock
    assert calls[0] == "freeze" and calls[-1] == "unfreeze"
    full = [i for i in range(len(calls) - 2) if calls[i:i + 3] == ["unfreeze", "collect", "freeze"]]
    assert len(full) == 1  # once in 700 s
    assert 650 <= calls.count("freeze") <= 750  # once a second, each after a collection of the young generations
    assert calls.count("collect") == calls.count("freeze") - 1  # (not before the first, at the start)
    assert heap.FULL_COLLECT_EVERY_S == 600.0 and heap.FREEZE_EVERY_S == 1.0


def _ready_daemon() -> Daemon:
    """A daemon whose roster is alive and plannable, its first step (stamp EPOCH_NS) released."""
    daemon = _daemon()
    alive = [Received("alive", f"gcs/vehicle/{v}/alive", b"", "", 0) for v in ROSTER]
    navs = [_sample(nav_key(v), NavReport(vehicle_id=v, seq=1, stamp_ns=EPOCH_NS, velocity_enu_mps=(25.0, 0.0, 0.0),
                                          heading_rad=0.0)) for v in ROSTER]
    _run(daemon, [(0.1, alive + navs + [_seen_from(v, EPOCH_NS) for v in ROSTER])])
    return daemon


def test_while_the_planner_process_starts_a_newer_step_replaces_the_job_waiting() -> None:
    """The process planner keeps a job submitted while its child starts; the newest step must win."""

    class Starting(_HeldPlanRunner):
        def submit(self, job) -> None:  # the child is not ready: the job waits, nothing is being planned
            self.jobs.append(job.stamp_ns)

    daemon = _ready_daemon()
    daemon.plan_runner.close()
    daemon.plan_runner = planner = Starting()
    for k in range(1, 8):
        daemon.zenoh.inbox.extend(_seen_from(v, EPOCH_NS + k * S) for v in ROSTER)
        daemon.turn(11.0 + 0.1 * k)
    assert planner.jobs[-1] == EPOCH_NS + 7 * S and len(planner.jobs) == 7


def test_a_step_is_not_timed_out_while_its_missing_report_waits_in_the_same_pass() -> None:
    """The loop is behind by more than max_wait_s: the step's last report is drained behind other items
    in the pass that times the step out; it is used, not rejected as late."""
    from protocols.keys import truth_key as key_of_truth

    daemon = _ready_daemon()
    try:
        daemon.zenoh.inbox.extend(_seen_from(v, EPOCH_NS + S) for v in ROSTER[:-1])
        daemon.turn(11.0)
        truths = [_sample(key_of_truth("target"), TargetTruth(target_id="target", seq=k, stamp_ns=EPOCH_NS + k * S,
                                                              position_enu_m=(0.0, 0.0), velocity_enu_mps=(0.0, 0.0)))
                  for k in range(len(ROSTER))]  # a roster's worth of other items first
        daemon.zenoh.inbox.extend(truths + [_seen_from(ROSTER[-1], EPOCH_NS + S)])
        daemon.turn(11.0 + 2 * daemon.options.max_wait_s)
    finally:
        daemon.plan_runner.close()
    assert "rejected.late" not in daemon.steps.counters
    (record,) = [r for r in daemon.records if r.stamp_ns == EPOCH_NS + S]
    assert all(record.seen[v] for v in ROSTER)


def test_a_loop_never_idle_still_collects_everything_it_froze(monkeypatch) -> None:
    import gc

    clock = [0.0]

    def tick() -> float:
        clock[0] += 1.0
        return clock[0]

    full_collections: list[float] = []
    monkeypatch.setattr(gc, "freeze", lambda: None)
    monkeypatch.setattr(gc, "unfreeze", lambda: full_collections.append(clock[0]))
    monkeypatch.setattr(gc, "collect", lambda *args: 0)
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(zenoh=ZenohSettings(), planner="pursuit", plan_runner="inline"),
                    clock=tick)
    daemon.zenoh = FakeZenoh()
    daemon.zenoh.open = lambda: None
    daemon.turn = lambda now: True  # always busy
    passes = []
    daemon.run(until=lambda: passes.append(1) or len(passes) > 1300)  # 1,300 s, never idle
    assert len(full_collections) == 2  # once, and the unfreeze when the loop ends
    assert 1200.0 <= full_collections[0] <= 1202.0  # at twice the interval


def test_a_withdrawn_token_is_seen_at_once_and_an_aged_heartbeat_within_the_refresh() -> None:
    """The loop reuses its set of vehicles alive (ALIVE_REFRESH_S): a liveliness change must not wait for
    the refresh (the step is released without the vehicle in the same pass), and a vehicle alive by
    MAVLink heartbeat alone is lost no later than the refresh after its heartbeat passes LOST_AFTER_S."""
    from gcs.daemon.app import ALIVE_REFRESH_S
    from gcs.engine.registry import LOST_AFTER_S

    daemon = _ready_daemon()
    gone, kept = ROSTER[0], ROSTER[1:]
    try:
        assert daemon._alive(11.0) == frozenset(ROSTER)
        timed_out = daemon.steps.counters["steps_released_by_timeout"]  # the first step always times out
        daemon.zenoh.inbox.extend([Received("gone", f"gcs/vehicle/{gone}/alive", b"", "", 0)]
                                  + [_seen_from(v, EPOCH_NS + S) for v in kept])
        daemon.turn(11.0 + ALIVE_REFRESH_S / 10)
        assert daemon._alive(11.0 + ALIVE_REFRESH_S / 10) == frozenset(kept)
        assert [r.stamp_ns for r in daemon.records][-1] == EPOCH_NS + S  # released complete, not timed out
        assert daemon.steps.counters["steps_released_by_timeout"] == timed_out

        heard_s = 12.0  # gone's heartbeat goes on after its token went, then stops at heard_s
        daemon.registry.heartbeat_age = lambda vehicle, now: now - heard_s if vehicle == gone else None
        assert gone in daemon._alive(heard_s + ALIVE_REFRESH_S)
        lost_s = heard_s + LOST_AFTER_S
        assert gone in daemon._alive(lost_s - ALIVE_REFRESH_S / 2)
        assert gone not in daemon._alive(lost_s + ALIVE_REFRESH_S)
    finally:
        daemon.plan_runner.close()
