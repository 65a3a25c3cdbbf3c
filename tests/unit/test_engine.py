"""The engine (:mod:`gcs.engine`) on scripted inputs: time only from its inputs, and the command age by hand."""

from __future__ import annotations

import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gcs.config.world import build_world
from gcs.daemon.plan_runners import run_job
from gcs.daemon.status_cli import format_status
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.events import Arrived, PlanDone, PlannerFree, PublishPlan, PublishTrack, SubmitPlan, Tick
from gcs.engine.memory import CommandAges
from gcs.engine.plan_jobs import PlanOutcome
from gcs.core.tracker import TrackerState
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key
from protocols.messages import DaemonStatus, Measurement, NavReport, SensorReport

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
ROSTER = [v.id for v in SCENARIO.vehicles]
S = 1_000_000_000
EPOCH_NS = 1_000_000 * S
ENGINE = Path(__file__).resolve().parents[2] / "gcs" / "engine"


def _arrived(key: str, message, now_s: float) -> Arrived:
    payload, encoding = encode(message)
    return Arrived("sample", key, payload, encoding, 0, now_s)


def _report(vehicle: str, stamp_ns: int) -> SensorReport:
    tx, ty = SCENARIO.target.start_enu_m
    ground = 300.0
    return SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, vehicle_position_enu_m=(tx - ground, ty, 200.0),
                        detections=(Measurement(range_m=math.hypot(ground, 200.0), range_std_m=10.0, azimuth_rad=0.0,
                                                azimuth_std_rad=0.05, elevation_rad=-math.atan2(200.0, ground),
                                                elevation_std_rad=0.05),))


def _nav(vehicle: str, stamp_ns: int) -> NavReport:
    return NavReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp_ns, velocity_enu_mps=(25.0, 0.0, 0.0), heading_rad=0.0)


def test_engine_modules_read_no_clock_open_no_socket_start_no_thread() -> None:
    forbidden = {"time", "socket", "threading", "multiprocessing", "random", "zenoh", "pymavlink", "datetime"}
    for path in sorted(ENGINE.glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                assert name.split(".")[0] not in forbidden, f"{path.name} imports {name}"
                assert not name.startswith("gcs.adapters"), f"{path.name} imports {name}"


def test_command_ages_are_the_vehicle_time_flown_less_the_planned_steps_stamp() -> None:
    """Step 0 (stamp E) is fused and planned; steering at vehicle times E + 2 s and E + 2.5 s (the newest
    stamps accepted then) gives three commands of 2000 ms and three of 2500 ms."""
    engine = Engine(SCENARIO, WORLD, EngineOptions(planner="pursuit"))
    for vehicle in ROSTER:
        engine.feed(Arrived("alive", alive_key(vehicle), b"", "", 0, 0.0))
        engine.feed(_arrived(nav_key(vehicle), _nav(vehicle, EPOCH_NS), 0.0))
        engine.feed(_arrived(report_key(vehicle), _report(vehicle, EPOCH_NS), 0.0))
    actions = engine.feed(Tick(10.0))  # the first step waits for its timeout
    assert [type(a) for a in actions] == [PublishTrack] and engine.loop.waiting is not None
    (submit,) = engine.feed(PlannerFree(10.0))
    assert isinstance(submit, SubmitPlan) and submit.job.stamp_ns == EPOCH_NS
    assert engine.steer() == [] and engine.command_ages.median_ms() is None  # nothing planned yet: no command
    outcome = run_job(submit.job, engine.subset(submit.job.indices), np.random.default_rng(0))
    published = engine.feed(PlanDone(outcome))
    assert [a.command.vehicle_id for a in published if isinstance(a, PublishPlan)] == ROSTER
    for k in (1, 2):
        for vehicle in ROSTER:
            engine.feed(_arrived(report_key(vehicle), _report(vehicle, EPOCH_NS + k * S), 10.0 + k))
    assert [vehicle for vehicle, _ in engine.steer()] == ROSTER
    for vehicle in ROSTER:
        engine.feed(_arrived(nav_key(vehicle), _nav(vehicle, EPOCH_NS + 5 * S // 2), 12.5))
    engine.steer()
    assert list(engine.command_ages.ages_ms) == [2000.0] * 3 + [2500.0] * 3
    assert engine.command_ages.median_ms() == 2250.0 and engine.command_ages.p99_ms() == 2500.0


def test_a_plan_job_with_nothing_to_plan_is_a_planning_error_and_the_engine_goes_on() -> None:
    engine = Engine(SCENARIO, WORLD, EngineOptions(planner="pursuit"))
    for vehicle in ROSTER:
        engine.feed(Arrived("alive", alive_key(vehicle), b"", "", 0, 0.0))
        engine.feed(_arrived(nav_key(vehicle), _nav(vehicle, EPOCH_NS), 0.0))
        engine.feed(_arrived(report_key(vehicle), _report(vehicle, EPOCH_NS), 0.0))
    engine.feed(Tick(10.0))
    (submit,) = engine.feed(PlannerFree(10.0))
    blind = replace(submit.job, state=TrackerState.start(len(ROSTER)))  # no estimate, no targets
    outcome = run_job(blind, engine.subset(blind.indices), np.random.default_rng(0))
    assert outcome.result is None and "nothing to plan" in (outcome.error or "")
    assert engine.feed(PlanDone(outcome)) == [] and engine.counters["errors.planning"] == 1
    silent = PlanOutcome(blind, None, None, None, 0.0, 0.0, 0)  # no plan, and no error said
    assert engine.feed(PlanDone(silent)) == [] and engine.counters["errors.planning"] == 2
    assert engine.counters["decisions"] == 0


def test_command_ages_keep_the_newest_and_the_p99_interpolates() -> None:
    ages = CommandAges(kept=100)
    for age_ms in range(1, 201):  # 1..200 ms; the newest 100 are 101..200
        ages.add(age_ms * 1_000_000, 0)
    assert len(ages.ages_ms) == 100 and ages.median_ms() == pytest.approx(150.5)
    assert ages.p99_ms() == pytest.approx(101 + 0.99 * 99)  # numpy's linear interpolation between ranks


def test_status_says_the_command_age_and_its_version_is_4() -> None:
    status = DaemonStatus(stamp_ns=1, uptime_s=0.0, scenario="city", vehicles=(), command_age_ms_median=812.4,
                          command_age_ms_p99=1930.0)
    assert DaemonStatus.VERSION == 4 and encode(status)[1].endswith("gcs.DaemonStatus/4")
    assert "command age median 812 ms, p99 1930 ms (vehicle time flown less the decision step's stamp)" in \
        format_status(status)
    assert not any("command age" in line for line in format_status(DaemonStatus(
        stamp_ns=1, uptime_s=0.0, scenario="city", vehicles=())))


def test_replay_releases_steps_for_the_vehicles_alive_by_their_recorded_heartbeats(tmp_path) -> None:
    """No liveliness tokens, as from vehicles on MAVLink only: with the heartbeats the daemon recorded a step waits
    for every vehicle's report; without them nobody is alive, each step goes with its first report, the rest late."""
    from gcs.adapters.recording import Recorder
    from gcs.recordings.replay import process

    with_beats, without = tmp_path / "heartbeats.mcap", tmp_path / "none.mcap"
    for path, beats in ((with_beats, True), (without, False)):
        with Recorder(path) as recorder:
            for k in range(6):
                t_ns = EPOCH_NS + k * S
                for slot, vehicle in enumerate(ROSTER):
                    if beats:
                        recorder.write_heartbeat(alive_key(vehicle), t_ns - S // 2)
                    recorder.write(nav_key(vehicle), *encode(_nav(vehicle, t_ns)), t_ns + slot * 10_000_000)
                    recorder.write(report_key(vehicle), *encode(_report(vehicle, t_ns)), t_ns + slot * 10_000_000)
    tracks, _, counters = process(with_beats, SCENARIO)
    assert len(tracks) == 6 and "rejected.late" not in counters and counters["steps_released_by_timeout"] == 1
    assert all(t.contributing_vehicles == tuple(ROSTER) for t in tracks)
    _, _, alone = process(without, SCENARIO)
    assert alone["rejected.late"] == 2 * 5  # steps 1-5 released with uav1's report
