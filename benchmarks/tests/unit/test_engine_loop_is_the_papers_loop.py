"""``gcs-bench urban``'s loop through the engine flies the paper's loop: the same runs as fuse-then-plan on the core.

The reference below is wang2012 section 4.3's loop written plainly on the core, with none of the engine: at each
1 s step the target moves, every UAV senses it with the simulator's sensor, the detections are fused
(:func:`gcs.core.tracker.fuse`), the planner plans (:func:`gcs.core.tracker.plan`), and the UAVs fly the first
turn rate for the step (eq. 1, :func:`gcs.core.kinematics.step_vehicles`). Its random streams are those the
benchmark's scene and planner draw from (``[seed, 1]`` the target, ``[seed, 2]`` the sensors, ``[seed, 3]`` the
planner). The engine's loop encodes every report as on the wire, assembles the steps, plans the released ones
and flies the plans' paths in 0.1 s ticks; what it sees and how far its track is from the car must be the
reference's, to rounding (the ticks' arcs differ from one 1 s arc in the last digits).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from benchmarks.urban import run_closed_loop
from benchmarks.urban_scene import start_of
from gcs.config.world import build_world
from gcs.core.filters.uif import NS_PER_S
from gcs.core.kinematics import step_vehicles
from gcs.core.tracker import Detection, TrackerState, fuse, plan
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import start_state, target_model

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
STEPS = 40
ERROR_ATOL_M = 1e-6
"""The two loops' track errors agree to this: the rounding of ten short arcs against one long one, grown over
40 steps of a chaotic closed loop, stays near 1e-9 m."""


def papers_loop(planner: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(seen (K, V), error of the track (K,)) of the plain loop (module docstring)."""
    config = tracker_config(SCENARIO, WORLD, planner)
    truth_rng, sensor_rng, plan_rng = (np.random.default_rng([seed, purpose]) for purpose in (1, 2, 3))
    model = target_model(SCENARIO, WORLD, None)
    target = start_state(model, SCENARIO, truth_rng)
    sensors = [TargetSensor.from_config(SCENARIO.sensor_for(v)) for v in SCENARIO.vehicles]
    vehicles, state = start_of(SCENARIO), TrackerState.start(len(SCENARIO.vehicles))
    dt = SCENARIO.time.step_s
    seen, errors = np.zeros((STEPS, len(sensors)), dtype=bool), np.full(STEPS, np.nan)
    for k in range(STEPS):
        if k > 0:
            target = model.step(target, dt, truth_rng)
            vehicles = step_vehicles(vehicles, state.turn_rate, dt, config.max_turn_rate)
        where = np.array([target.position[0], target.position[1], 0.0])
        detections = []
        for i, sensor in enumerate(sensors):
            observed = sensor.observe(where, vehicles.xyz[i:i + 1], WORLD.line_of_sight, sensor_rng)
            if observed.detected[0]:
                detections.append(Detection(i, vehicles.xyz[i], observed.values[0]))
                seen[k, i] = True
        estimate = fuse(config, state.estimate, round(k * dt * NS_PER_S), detections)
        state, _, _ = plan(config, replace(state, estimate=estimate), vehicles, plan_rng)
        if state.estimate is not None:
            errors[k] = float(np.hypot(*(state.estimate.mean[:2] - target.position)))
    return seen, errors


@pytest.mark.parametrize(("planner", "seed"), [("sight", 2012), ("orbit", 2013)])
def test_the_engine_loop_sees_and_tracks_as_the_papers_loop(planner: str, seed: int) -> None:
    seen, errors = papers_loop(planner, seed)
    assert seen.any(axis=1).sum() > STEPS // 2 and np.isfinite(errors).sum() > STEPS // 2  # a run worth comparing
    record = run_closed_loop(SCENARIO, WORLD, planner, seed, duration_s=STEPS * SCENARIO.time.step_s, clock=None)
    np.testing.assert_array_equal(record.seen, seen)
    np.testing.assert_allclose(record.errors_m, errors, rtol=0.0, atol=ERROR_ATOL_M)
