"""The benchmarks' closed loop (benchmarks/closed_loop.py): the engine decides, the vehicles fly its plans.

Independent figures: the engine's own counters (every step fused and planned, only the first released by
its reorder window), the kinematics' rollout of each planned turn rate (wang2012 eq. 1) against where the
vehicles went, and circle geometry for a vehicle left alone.
"""

from __future__ import annotations

import numpy as np

from benchmarks.closed_loop import SUBSTEP_S, IdealAirframes, Loiter
from benchmarks.urban import run_closed_loop
from gcs.config.world import build_world
from gcs.core.kinematics import VehicleState, step_vehicles
from gcs.core.steering import PlannedPath
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
SPEEDS = np.array([v.speed_mps for v in SCENARIO.vehicles])
ALTITUDES = np.array([v.altitude_m for v in SCENARIO.vehicles])
ETA = np.array([v.max_turn_rate_rad_s for v in SCENARIO.vehicles])


def test_every_step_goes_through_the_engine_and_is_planned_and_only_the_first_is_released_by_its_window() -> None:
    record = run_closed_loop(SCENARIO, WORLD, "sight", 5, duration_s=30.0, clock=None)
    counters = record.counters
    assert counters["accepted.report"] == 3 * 30 and counters["accepted.truth"] == 30
    # the first step has no step before it to say it is complete: its (zero, in process) window releases it
    assert counters["decisions"] == 30 and counters["steps_released_by_timeout"] == 1
    assert not any(name.startswith("rejected.") for name in counters), counters
    assert np.isfinite(record.planned_turn_rate).all()


def test_the_vehicles_fly_each_steps_planned_turn_rate_as_wang2012_eq1() -> None:
    record = run_closed_loop(SCENARIO, WORLD, "ga_k5", 8, duration_s=25.0, clock=None, generations=5)
    for k in range(1, 24):  # step 0 is planned once its reorder window is over: half a step of straight flight
        now = VehicleState(record.vehicle_xy[k], record.heading[k], SPEEDS, ALTITUDES)
        flown = step_vehicles(now, record.planned_turn_rate[k], 1.0, ETA)
        np.testing.assert_allclose(flown.xy, record.vehicle_xy[k + 1], atol=1e-6)
    assert np.abs(record.planned_turn_rate[1:]).max() > 0.01  # they do turn


def test_the_runs_do_not_depend_on_the_clock() -> None:
    timed = run_closed_loop(SCENARIO, WORLD, "sight", 3, duration_s=15.0)
    untimed = run_closed_loop(SCENARIO, WORLD, "sight", 3, duration_s=15.0, clock=None)
    np.testing.assert_array_equal(timed.vehicle_xy, untimed.vehicle_xy)
    np.testing.assert_array_equal(timed.errors_m, untimed.errors_m)
    assert np.isfinite(timed.decision_s).all() and np.isnan(untimed.decision_s).all()


def _airframes(homes=None) -> IdealAirframes:
    start = VehicleState(np.array([[0.0, 0.0]]), np.array([0.0]), np.array([25.0]), np.array([200.0]))
    return IdealAirframes(["uav1"], start, np.array([0.2]), 1.0, 150.0, homes)


def _fly(airframes: IdealAirframes, seconds: float, paths=None, start_s: float = 0.0) -> list[np.ndarray]:
    flown = []
    for tick in range(round(seconds / SUBSTEP_S)):
        airframes.fly(SUBSTEP_S, airframes.turn_rates(start_s + tick * SUBSTEP_S, paths or {}))
        flown.append(airframes.state.xy[0].copy())
    return flown


def test_a_vehicle_never_steered_holds_its_course() -> None:
    airframes = _airframes()
    _fly(airframes, 10.0)
    np.testing.assert_allclose(airframes.state.xy[0], [250.0, 0.0], atol=1e-9)


def test_a_vehicle_whose_plan_ran_out_loiters_where_it_stopped_on_the_loiter_radius() -> None:
    airframes = _airframes()
    path = PlannedPath.from_plan(airframes.state, np.full(3, 0.1), 1.0, 0.2)
    steered = _fly(airframes, 3.0, {"uav1": (path, 0.0)})
    np.testing.assert_allclose(steered[-1], path.points[-1], atol=1e-6)  # it flew its plan
    stopped = steered[-1]
    circling = np.array(_fly(airframes, 120.0, start_s=3.0))[-300:]  # the last 30 s, well on the circle
    radius = np.hypot(*(circling - stopped).T)
    np.testing.assert_allclose(radius, 150.0, rtol=0.05)


def test_a_vehicle_with_a_home_circle_loiters_there_when_not_steered() -> None:
    airframes = _airframes([Loiter((1000.0, 0.0), 400.0)])
    circling = np.array(_fly(airframes, 240.0))[-300:]
    np.testing.assert_allclose(np.hypot(*(circling - [1000.0, 0.0]).T), 400.0, rtol=0.05)
