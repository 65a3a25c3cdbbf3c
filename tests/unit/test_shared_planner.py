"""UAVs shared between targets: the priority weights, the summed objective and the assignment alternative."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gcs.core.filters.uif import GaussianEstimate
from gcs.core.kinematics import VehicleState
from gcs.core.planners.problem import PlanningProblem
from gcs.core.planners.sequential import SightPlanner
from gcs.core.planners.shared import (SharedView, assign_vehicles, shared_joint_values, target_weights,
                                      vehicles_subproblem)
from gcs.core.planners.sight import SightModel, TeamView, joint_values
from gcs.core.tracker import prediction
from gcs.config.world import build_world
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario

SCENARIO = load_scenario("wang2012_urban")
CONFIG = tracker_config(SCENARIO, build_world(SCENARIO), "sight")
VEHICLES = VehicleState(np.array([[1300.0, 1400.0], [1700.0, 1500.0], [1500.0, 1800.0]]),
                        np.array([0.0, 2.0, -1.5]), np.full(3, 25.0), np.array([200.0, 210.0, 220.0]))


def _problem(x: float, y: float) -> PlanningProblem:
    estimate = GaussianEstimate(np.array([x, y, 8.0, 0.0]), np.diag([400.0, 400.0, 4.0, 4.0]), 0)
    predicted = prediction(CONFIG, estimate)
    return PlanningProblem(VEHICLES, np.zeros(3), CONFIG.max_turn_rate, CONFIG.step_s, predicted.states.mean,
                           predicted.states.cov, CONFIG.sensors, None, None, CONFIG.weights, CONFIG.sight,
                           CONFIG.guard, CONFIG.max_range_m)


def test_weights_follow_priority_and_the_time_unseen() -> None:
    np.testing.assert_allclose(target_weights([1.0, 1.0], [0.0, 0.0], 30.0), [0.5, 0.5])
    # claims 1 * (1 + 0) and 2 * (1 + 60 / 30) = 6
    np.testing.assert_allclose(target_weights([1.0, 2.0], [0.0, 60.0], 30.0), [1 / 7, 6 / 7])
    for bad in (([0.0], [0.0], 1.0), ([1.0], [-1.0], 1.0), ([1.0], [0.0], 0.0), ([1.0, 1.0], [0.0], 1.0)):
        with pytest.raises(ValueError):
            target_weights(*bad)


def test_one_target_with_weight_one_is_the_single_target_objective() -> None:
    problem = _problem(1500.0, 1500.0)
    model = SightModel.build(problem, CONFIG.planner.weights)
    plans = np.random.default_rng(0).uniform(-0.1, 0.1, (7, 3, CONFIG.horizon_steps))
    np.testing.assert_array_equal(shared_joint_values([model], np.ones(1), plans), joint_values(model, plans))
    shared, single = SharedView([model], np.ones(1), plans[0]), TeamView(model, plans[0])
    np.testing.assert_array_equal(shared.values(1, plans[:, 1])[0], single.values(1, plans[:, 1])[0])


def test_the_summed_objective_is_the_weighted_sum_of_each_targets() -> None:
    problems = [_problem(1500.0, 1500.0), _problem(2200.0, 900.0)]
    models = [SightModel.build(p, CONFIG.planner.weights) for p in problems]
    weights = np.array([0.3, 0.7])
    plans = np.random.default_rng(1).uniform(-0.1, 0.1, (5, 3, CONFIG.horizon_steps))
    expected = 0.3 * joint_values(models[0], plans) + 0.7 * joint_values(models[1], plans)
    np.testing.assert_allclose(shared_joint_values(models, weights, plans), expected, rtol=1e-12)
    view = SharedView(models, weights, plans[0])
    values, parts = view.values(2, plans[:, 2])
    whole = plans[:1].repeat(5, axis=0)
    whole[:, 2] = plans[:, 2]
    np.testing.assert_allclose(values, shared_joint_values(models, weights, whole), rtol=1e-9)
    view.accept(2, plans[:, 2], parts, 3)
    np.testing.assert_array_equal(view.controls[2], plans[3, 2])


def test_the_shared_plan_is_never_worse_than_its_starting_plans() -> None:
    problems = [_problem(1500.0, 1500.0), _problem(2200.0, 900.0), _problem(900.0, 2300.0)]
    weights = target_weights([1.0, 1.0, 2.0], [0.0, 10.0, 0.0], 30.0)
    planner = SightPlanner(CONFIG.planner.weights)
    warm = np.random.default_rng(2).uniform(-0.1, 0.1, (3, CONFIG.horizon_steps))
    result = planner.solve_shared(problems, weights, np.random.default_rng(2), warm)
    models = [SightModel.build(p, CONFIG.planner.weights) for p in problems]
    starts = planner.starts(problems[0], warm, problems[1:])
    assert len(starts) == 1 + 2 * 3 + 2  # straight, orbit and pursuit of each target, two shifted warm starts
    values = shared_joint_values(models, weights, np.concatenate([result.controls[None], starts]))
    assert values[0] >= values[1:].max() - 1e-9
    assert result.fitness == pytest.approx(values[0], abs=1e-9)


def test_assignment_gives_every_target_a_vehicle_before_any_gets_two() -> None:
    targets = np.array([[1300.0, 1450.0], [1700.0, 1450.0]])  # both nearer uav0 / uav1 than uav2
    assigned = assign_vehicles(VEHICLES, targets, np.array([0.5, 0.5]))
    assert sorted(assigned[:2].tolist()) == [0, 1] and assigned[0] == 0
    assert set(assigned.tolist()) == {0, 1}
    # four targets 500 m from the vehicles and one far: equal weights leave the far one out, a
    # heavy weight (cost d / w) wins it a vehicle
    many = VEHICLES.xy + np.array([500.0, 0.0])
    many = np.vstack([many, [[3000.0, 3000.0]]])
    assert 3 not in assign_vehicles(VEHICLES, many, np.full(4, 0.25))
    assigned = assign_vehicles(VEHICLES, many, np.array([0.01, 0.01, 0.01, 0.97]))
    assert len(set(assigned.tolist())) == 3 and 3 in assigned


def test_a_subproblem_keeps_the_chosen_vehicles_rows() -> None:
    problem = replace(_problem(1500.0, 1500.0), current_turn_rate=np.array([0.01, 0.02, 0.03]))
    sub = vehicles_subproblem(problem, [2, 0])
    np.testing.assert_array_equal(sub.vehicles.xy, VEHICLES.xy[[2, 0]])
    np.testing.assert_array_equal(sub.current_turn_rate, [0.03, 0.01])
    assert list(sub.sensors) == [problem.sensors[2], problem.sensors[0]]
    np.testing.assert_array_equal(sub.target_means, problem.target_means)


def test_assigned_planning_plans_each_target_with_its_own_vehicles() -> None:
    problems = [_problem(1300.0, 1450.0), _problem(1700.0, 1450.0)]
    planner = SightPlanner(CONFIG.planner.weights)
    result = planner.solve_assigned(problems, np.array([0.5, 0.5]), np.random.default_rng(3))
    assigned = assign_vehicles(VEHICLES, np.array([[1300.0, 1450.0], [1700.0, 1450.0]]), np.array([0.5, 0.5]))
    for k in (0, 1):
        idx = np.flatnonzero(assigned == k)
        sub = vehicles_subproblem(problems[k], idx)
        model = SightModel.build(sub, CONFIG.planner.weights)
        # each group's plan is at least as good, on its own target, as every plan its search started from
        starts = planner.starts(sub, None)
        assert joint_values(model, result.controls[idx][None])[0] >= joint_values(model, starts).max() - 1e-9
    assert result.message == f"assigned {assigned.tolist()}"
