"""The road tracker in the tracking loop (gcs.core.tracker): seeded from the inputs, given the looks of the vehicles
that saw nothing, and planned on through the samples of its branches.

Figures compared with: a T-junction met from its stem splits the road mass 1 : 1 between its arms (no straight
option); a UAV that had the west arm in sight and saw nothing leaves it ``0.5 (1 - P_D) / (0.5 (1 - P_D) + 0.5)``
= 1/11 of the arms' mass for ``P_D = 0.9`` (Bayes' rule); systematic resampling to ``B`` samples keeps every
branch's weight to within ``1 / B``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gcs.config.world import build_world
from gcs.core.filters.estimate import ns_from_s
from gcs.core.kinematics import VehicleState
from gcs.core.planners.problem import PlanningProblem
from gcs.core.planners.sight import SightModel, SightWeights
from gcs.core.roads import RoadHorizon, RoadParticleFilter
from gcs.core.roads.tracking import RoadTracking
from gcs.core.tracker import Detection, Sensing, TrackerState, fuse, plan, prediction
from gcs.core.world import Buildings
from gcs.core.world.sight_table import HeightField, SightTable
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario
from tests.unit.roads._scenes import SENSOR, T_JUNCTION, detections, edge_of, mass_on, on_stem

WEST = edge_of(T_JUNCTION, (0, 0), (-300, 0))
EAST = edge_of(T_JUNCTION, (0, 0), (300, 0))
SCENARIO = load_scenario("fast_target")  # a car in a city with roads: the road tracker by default
CONFIG = tracker_config(SCENARIO, build_world(SCENARIO), "sight")
OPEN_SKY = SightTable(HeightField.from_buildings(Buildings.empty()), 150.0, SENSOR.target_height_m, reach_m=170.0)


def _on_the_junction(seed: int = 0, sees=None):
    """The loop's tracker on the hand-built T-junction, and a track 20 s unseen after on_stem() (100 m past the node)."""
    road = RoadTracking(RoadParticleFilter(T_JUNCTION, particles=2000), sees=sees, seed=seed)
    config = replace(CONFIG, road=road, sensors=(SENSOR,) * 3)
    start = road.start(on_stem(), [], None)
    return config, road.step(start, ns_from_s(20.0), [], None)


def test_a_road_track_is_a_function_of_its_inputs_and_seed() -> None:
    config = replace(CONFIG, road=replace(CONFIG.road, seed=1))
    rng = np.random.default_rng(3)
    vehicles = np.array([[1400.0, 1300.0, 200.0], [1700.0, 1600.0, 210.0], [1500.0, 1900.0, 220.0]])
    steps = [[Detection(v, vehicles[v], group[1][v]) for v in range(3)]
             for group in (detections((1500.0 + 10.0 * k, 1500.0), vehicles, SENSOR, rng)[0] for k in range(4))]

    def track(cfg):
        estimate = None
        for k, found in enumerate(steps):
            estimate = fuse(cfg, estimate, ns_from_s(float(k)), found, Sensing(vehicles, np.ones(3, dtype=bool)))
        return estimate

    a, b, other = track(config), track(config), track(replace(config, road=replace(config.road, seed=2)))
    np.testing.assert_array_equal(a.mean, b.mean)
    np.testing.assert_array_equal(a.particles.xy, b.particles.xy)
    np.testing.assert_array_equal(prediction(config, a).samples, prediction(config, b).samples)
    assert not np.array_equal(a.particles.xy, other.particles.xy)
    # 4 detections from 3 UAVs each, at most 500 m away: the track is on the car, east along y = 1500
    assert np.hypot(*(a.mean[:2] - (1530.0, 1500.0))) < 15.0


def test_the_looks_of_a_step_reach_the_road_tracker() -> None:
    def sees(points, vehicle_xyz):  # the one UAV sees the west arm, from 5 m west of the node on
        return np.broadcast_to(points[:, 0] < -5.0, (len(vehicle_xyz), len(points)))

    config, prior = _on_the_junction(seed=4, sees=sees)
    stamp = ns_from_s(21.0)
    looked = fuse(config, prior, stamp, [], Sensing(np.array([[-150.0, 0.0, 200.0]]), np.array([False])))
    blind = fuse(config, prior, stamp, [], None)
    share = {name: mass_on(e, WEST) / (mass_on(e, WEST) + mass_on(e, EAST))
             for name, e in (("looked", looked), ("blind", blind))}
    # 1/11 and 1/2 (module docstring); 0.04 allows for the mass near the node the look misses, and sampling
    assert share["looked"] == pytest.approx(1.0 / 11.0, abs=0.04)
    assert share["blind"] == pytest.approx(0.5, abs=0.04)


def test_the_planner_samples_the_branches_of_the_road_prediction() -> None:
    config, estimate = _on_the_junction(seed=5)
    horizon = prediction(config, estimate)
    assert isinstance(horizon, RoadHorizon) and horizon.samples.shape == (config.horizon_steps, 64, 2)
    vehicles = VehicleState(np.array([[-175.0, 0.0], [175.0, 0.0]]), np.zeros(2), np.full(2, 20.0), np.full(2, 150.0))
    problem = PlanningProblem(vehicles, np.zeros(2), np.full(2, 0.2), 1.0, horizon.states.mean, horizon.states.cov,
                              (SENSOR, SENSOR), None, None, sight=OPEN_SKY,
                              target_samples=horizon.samples, target_sample_weights=horizon.weights)
    weights = SightWeights()
    model = SightModel.build(problem, weights)
    last, thinned = horizon.samples[-1], model.samples[-1]
    assert model.samples.shape == (config.horizon_steps, weights.branch_samples, 2)
    # every sample the objective scores is one of the prediction's: on the road, down one arm or the other
    assert all(np.any(np.all(point == last, axis=1)) for point in thinned)
    west_arm, east_arm = _on_arm(last, -1.0), _on_arm(last, 1.0)
    assert min(horizon.weights[-1][west_arm].sum(), horizon.weights[-1][east_arm].sum()) > 0.3
    for sign in (-1.0, 1.0):
        assert model.weights[-1][_on_arm(thinned, sign)].sum() == pytest.approx(
            horizon.weights[-1][_on_arm(last, sign)].sum(), abs=1.0 / weights.branch_samples)
    # a UAV held over each arm, 175 m out, sees every sample on its arm and none on the other (open sky, 170 m
    # reach, the arms 300 m long): the objective's q of each is its arm's weight, plus at most the off-road samples'
    held = np.broadcast_to(vehicles.xy[:, None, :], (2, config.horizon_steps, 2))
    off_road = model.weights[-1][~_on_arm(thinned, -1.0) & ~_on_arm(thinned, 1.0)].sum()
    for i, sign in enumerate((-1.0, 1.0)):
        q = float(model.visible(held[i:i + 1], 150.0)[0, -1] @ model.weights[-1])
        arm = model.weights[-1][_on_arm(thinned, sign)].sum()
        assert arm - 1e-12 <= q <= arm + off_road + 1e-12


def _on_arm(points: np.ndarray, sign: float) -> np.ndarray:
    """Which points lie on the west (sign -1) or east (+1) arm of the T-junction."""
    return (sign * points[:, 0] > 0.5) & (np.abs(points[:, 0]) <= 300.0) & (np.abs(points[:, 1]) < 1e-6)


def test_every_planner_plans_on_a_road_track() -> None:
    world = build_world(SCENARIO)
    uav = np.array([[1400.0, 1400.0, 200.0]])
    _, values, _, _ = detections((1500.0, 1500.0), uav, SENSOR, np.random.default_rng(6))[0]
    estimate = fuse(CONFIG, None, 0, [Detection(0, uav[0], values[0])])
    vehicles = VehicleState(np.array([[1200.0, 1200.0], [1800.0, 1300.0], [1500.0, 1900.0]]), np.zeros(3),
                            np.full(3, 18.0), np.array([200.0, 210.0, 220.0]))
    for planner in ("sight", "sight_k0", "ga_k5", "orbit", "pursuit"):
        config = tracker_config(SCENARIO, world, planner, generations=3)
        state, turn_rates, diagnostics = plan(config, TrackerState(estimate, None, np.zeros(3)), vehicles,
                                              np.random.default_rng(6))
        assert turn_rates.shape == (3,) and np.all(np.abs(turn_rates) <= config.max_turn_rate + 1e-12), planner
        assert isinstance(diagnostics.prediction, RoadHorizon) == config.predict_ahead, planner
        # orbit and pursuit aim at the point estimate: the moment-matched mean, near the detection's ground point
        assert np.hypot(*(diagnostics.prediction.positions[0] - (1500.0, 1500.0))) < 60.0, planner
