"""The engine with ``[multitarget]`` on scripted inputs: tracks confirmed, published and retired; targets planned.

Two cars stand still 400 m apart; the three vehicles report exact range, azimuth and
elevation to each (wang2012 eq. 3-4: ``rho = |d|``, ``phi = atan2(dy, dx)``,
``theta = atan2(dz, |d_xy|)``). With the scenario's 3-of-4 rule the tracks are confirmed
on the third scan; once one car's detections stop, its track is retired after
``max_misses`` scans (no world: every track counts as covered).
"""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest

from gcs.config.world import build_world
from gcs.daemon.plan_runners import run_job
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.events import Arrived, PlanDone, PlannerFree, PublishPlan, PublishTrack, RetireTrack, SubmitPlan, Tick
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key
from protocols.messages import Measurement, NavReport, SensorReport

SCENARIO = load_scenario("multitarget_urban")
ROSTER = [v.id for v in SCENARIO.vehicles]
S = 1_000_000_000
EPOCH_NS = 1_000_000 * S
CARS = {"a": (1500.0, 1500.0), "b": (1900.0, 1500.0)}
VEHICLES = {"uav1": (1500.0, 1100.0, 200.0), "uav2": (1900.0, 1100.0, 210.0), "uav3": (1700.0, 1900.0, 220.0)}


def _measurement(vehicle: tuple[float, float, float], car: tuple[float, float]) -> Measurement:
    dx, dy, dz = car[0] - vehicle[0], car[1] - vehicle[1], -vehicle[2]
    return Measurement(range_m=math.sqrt(dx * dx + dy * dy + dz * dz), range_std_m=10.0,
                       azimuth_rad=math.atan2(dy, dx), azimuth_std_rad=0.05,
                       elevation_rad=math.atan2(dz, math.hypot(dx, dy)), elevation_std_rad=0.05)


def _scan(engine: Engine, k: int, cars: tuple[str, ...], now_s: float) -> list:
    """Every vehicle's report of step k, seeing ``cars``; the actions of the tick after them."""
    for vehicle, xyz in VEHICLES.items():
        report = SensorReport(vehicle_id=vehicle, seq=k + 1, stamp_ns=EPOCH_NS + k * S, vehicle_position_enu_m=xyz,
                              detections=tuple(_measurement(xyz, CARS[c]) for c in cars))
        nav = NavReport(vehicle_id=vehicle, seq=k + 1, stamp_ns=EPOCH_NS + k * S, velocity_enu_mps=(25.0, 0.0, 0.0),
                        heading_rad=0.0)  # what the planner needs of a vehicle besides its position
        for key, message in ((nav_key(vehicle), nav), (report_key(vehicle), report)):
            payload, encoding = encode(message)
            engine.feed(Arrived("sample", key, payload, encoding, 0, now_s))
    return engine.feed(Tick(now_s))


def _engine(world) -> Engine:
    engine = Engine(SCENARIO, world, EngineOptions())
    for vehicle in ROSTER:
        engine.feed(Arrived("alive", alive_key(vehicle), b"", "", 0, 0.0))
    return engine


def test_tracks_are_confirmed_on_the_third_scan_published_by_id_and_retired_when_their_car_is_gone() -> None:
    engine = _engine(None)
    published = []
    for k in range(3):
        actions = _scan(engine, k, ("a", "b"), 10.0 * (k + 1))
        published.append([a.track for a in actions if isinstance(a, PublishTrack)])
    assert published[0] == [] and published[1] == []  # tentative: 1 and 2 hits of the 3 needed
    tracks = {t.target_id: t for t in published[2]}
    assert len(tracks) == 2 and all(name.startswith("t") for name in tracks)
    for car in CARS.values():  # one track on each car, within the sensor's few metres at 400 m
        assert min(math.hypot(t.state[0] - car[0], t.state[1] - car[1]) for t in tracks.values()) < 15.0
    assert {t.seq for t in tracks.values()} == {1} and all(t.contributing_vehicles == tuple(ROSTER)
                                                             for t in tracks.values())
    assert all(engine.records[-1].seen.values())
    on_b = min(tracks, key=lambda name: abs(tracks[name].state[0] - CARS["b"][0]))
    retired_at = None
    for k in range(3, 3 + SCENARIO.multitarget.max_misses + 1):
        actions = _scan(engine, k, ("a",), 10.0 * (k + 1))
        if any(isinstance(a, RetireTrack) for a in actions):
            assert [a.target_id for a in actions if isinstance(a, RetireTrack)] == [on_b]
            retired_at = k
            break
        assert {a.track.target_id for a in actions if isinstance(a, PublishTrack)} == set(tracks)
    assert retired_at == 2 + SCENARIO.multitarget.max_misses  # after max_misses scans without a detection
    assert set(engine.tracks_now) == set(tracks) - {on_b}


def test_the_confirmed_tracks_are_planned_for_together_and_every_vehicle_gets_a_plan() -> None:
    engine = _engine(build_world(SCENARIO))
    for k in range(3):
        _scan(engine, k, ("a", "b"), 10.0 * (k + 1))
    (submit,) = engine.feed(PlannerFree(40.0))
    assert isinstance(submit, SubmitPlan) and submit.job.state.estimate is None
    targets = submit.job.targets
    assert set(targets.ids) == set(engine.tracks_now) and targets.weights == pytest.approx([0.5, 0.5])
    horizon = engine.tracker.horizon_steps
    assert targets.means.shape == (2, horizon, 4) and targets.covs.shape == (2, horizon, 4, 4)
    outcome = run_job(submit.job, engine.subset(submit.job.indices), np.random.default_rng(0))
    assert outcome.error is None and outcome.result.message.startswith("assigned")
    plans = [a.command for a in engine.feed(PlanDone(outcome)) if isinstance(a, PublishPlan)]
    assert [p.vehicle_id for p in plans] == ROSTER
    limits = [v.max_turn_rate_rad_s for v in SCENARIO.vehicles]
    assert all(abs(p.turn_rate_rad_s) <= limit + 1e-9 for p, limit in zip(plans, limits))


def test_a_planner_that_cannot_share_the_vehicles_is_refused() -> None:
    with pytest.raises(ValueError, match="cannot share the vehicles between targets"):
        Engine(SCENARIO, None, EngineOptions(planner="orbit"))


def _record_two_cars(path) -> None:
    """Six steps recorded with the vehicles' heartbeats, nav, reports of both cars (exact), and the cars' truths
    3-4-5 m off them."""
    from gcs.adapters.recording import Recorder
    from protocols.keys import truth_key
    from protocols.messages import TargetTruth

    with Recorder(path) as recorder:
        for k in range(6):
            t_ns = EPOCH_NS + k * S
            for name, xy in CARS.items():
                truth = TargetTruth(target_id=name, seq=k + 1, stamp_ns=t_ns, position_enu_m=(xy[0] + 3.0, xy[1] + 4.0),
                                    velocity_enu_mps=(0.0, 0.0))
                recorder.write(truth_key(name), *encode(truth), t_ns)
            for slot, (vehicle, xyz) in enumerate(VEHICLES.items()):
                recorder.write_heartbeat(alive_key(vehicle), t_ns - S // 2)
                nav = NavReport(vehicle_id=vehicle, seq=k + 1, stamp_ns=t_ns, velocity_enu_mps=(25.0, 0.0, 0.0),
                                heading_rad=0.0)
                report = SensorReport(vehicle_id=vehicle, seq=k + 1, stamp_ns=t_ns, vehicle_position_enu_m=xyz,
                                      detections=tuple(_measurement(xyz, car) for car in CARS.values()))
                recorder.write(nav_key(vehicle), *encode(nav), t_ns + slot * 10_000_000)
                recorder.write(report_key(vehicle), *encode(report), t_ns + slot * 10_000_000)


def test_replay_tracks_and_plans_every_car_of_a_recording_and_scores_the_tracks_by_gospa(tmp_path) -> None:
    """Replay (the Gaussian tracker, named) confirms a track on each car from the third step and plans every
    decision for all three vehicles. The reports measure the cars exactly, so the tracks are on them; the truths
    are 5 m off, so each step with tracks has GOSPA sqrt(5^2 + 5^2) m (no car missed, no false track)."""
    from gcs.recordings.replay import process, truth_gospa

    path = tmp_path / "cars.mcap"
    _record_two_cars(path)
    gaussian = msgspec.structs.replace(SCENARIO, multitarget=msgspec.structs.replace(SCENARIO.multitarget,
                                                                                     kind="gaussian"))
    tracks, plans, counters = process(path, gaussian, world=build_world(SCENARIO))
    assert counters.get("errors.decision", 0) == 0 and counters.get("errors.planning", 0) == 0, counters
    assert sorted({t.stamp_ns for t in tracks}) == [EPOCH_NS + k * S for k in range(2, 6)]
    assert len(tracks) == 2 * 4 and len({t.target_id for t in tracks}) == 2
    assert len(plans) == 3 * counters["decisions"] and counters["decisions"] >= 4
    errors = [min(math.hypot(t.state[0] - x, t.state[1] - y) for x, y in CARS.values()) for t in tracks]
    mean, scored = truth_gospa(path, tracks, S)
    # steps 0-1 have no track: both cars missed, sqrt(2 c^2 / 2) = c = 100 m
    assert scored == 6 and max(errors) < 1e-6 and mean == pytest.approx((2 * 100.0 + 4 * math.sqrt(50.0)) / 6,
                                                                         abs=1e-6)


def test_replay_in_a_city_with_roads_runs_the_road_tracker_the_same_twice(tmp_path) -> None:
    """The scenario's own ``[multitarget]`` (``kind = "auto"``, a generated city): the road tracker. It confirms
    the same two tracks at the same steps as the Gaussian one; its tracks are its clouds' means, within 10 m of
    the cars (the clouds' lane offset, ``lane_std_m`` 4 m, and road spread, 3 m, about points measured exactly);
    and a second replay gives the same tracks bit for bit (its draws seeded by the scenario and the stamps)."""
    from gcs.recordings.replay import process

    path = tmp_path / "cars.mcap"
    _record_two_cars(path)
    world = build_world(SCENARIO)
    assert Engine(SCENARIO, world, EngineOptions()).keeper.road is not None
    tracks, _, counters = process(path, SCENARIO, world=world, plan=False)
    again, _, _ = process(path, SCENARIO, world=world, plan=False)
    assert counters.get("errors.decision", 0) == 0, counters
    assert sorted({t.stamp_ns for t in tracks}) == [EPOCH_NS + k * S for k in range(2, 6)]
    assert len(tracks) == 2 * 4 and len({t.target_id for t in tracks}) == 2
    assert max(min(math.hypot(t.state[0] - x, t.state[1] - y) for x, y in CARS.values()) for t in tracks) < 10.0
    assert [(t.target_id, t.stamp_ns, t.state, t.covariance) for t in tracks] == \
        [(t.target_id, t.stamp_ns, t.state, t.covariance) for t in again]


def test_the_vehicles_are_given_back_once_there_is_nothing_to_track_or_search_for() -> None:
    """Cars seen on scans 0-2, then never: the tracks coast unseen (nobody sees a car, but there is still a
    track to plan for), are deleted on scan 7 and, unseen 5 s > ``forget_s`` 3 s, not searched for; with a
    2 s hand-back the vehicles are let go on scan 8, 2 s after scan 6, the last with something to plan for."""
    from gcs.engine.events import LetGo

    scenario = msgspec.structs.replace(SCENARIO, multitarget=msgspec.structs.replace(SCENARIO.multitarget,
                                                                                      forget_s=3.0))
    engine = Engine(scenario, None, EngineOptions(handback_after_lost_s=2.0))
    for vehicle in ROSTER:
        engine.feed(Arrived("alive", alive_key(vehicle), b"", "", 0, 0.0))
    let_go = []
    for k in range(11):
        actions = _scan(engine, k, ("a", "b") if k < 3 else (), 10.0 * (k + 1))
        let_go += [k for a in actions if isinstance(a, LetGo)]
        if k == 6:
            assert len(engine.tracks_now) == 2 and not any(engine.records[-1].seen.values())
    assert let_go == [8] and engine.tracks_now == {}
