"""GA for the RHC problem (wang2012 section 4.2) and the baselines, on problems with known answers."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from gcs.core.kinematics import step_vehicles
from gcs.core.planners import GeneticPlanner, OrbitPlanner, PursuitPlanner, evaluate, shift_plan
from tests.unit.test_planner_cost import _problem


class HalfPlane:
    """Visible only north of the line y = y0 (the target is seen from one side of a street)."""

    def __init__(self, y0: float) -> None:
        self.y0 = y0

    def visible(self, xy: np.ndarray) -> np.ndarray:
        return xy[..., 1] > self.y0


def test_ga_turns_toward_the_side_from_which_the_target_is_visible() -> None:
    problem = replace(_problem(), visibility=HalfPlane(1510.0))
    result = GeneticPlanner(population=30, generations=60, deadline_s=None).solve(problem, np.random.default_rng(0))
    # Both vehicles fly along y = 1500 (east and west); seeing the target needs y > 1510, i.e. a left
    # turn for the east-bound vehicle (positive rate) and a right turn for the west-bound one.
    assert result.controls[0, 0] > 0.0 and result.controls[1, 0] < 0.0
    assert result.visible_steps > 0
    straight = evaluate(problem, np.zeros((1, 2, 5))).fitness[0]
    assert result.fitness > straight


def test_ga_respects_bounds_keeps_its_elite_and_is_deterministic() -> None:
    problem = _problem()
    planner = GeneticPlanner(population=20, generations=25, deadline_s=None)
    a = planner.solve(problem, np.random.default_rng(42))
    b = planner.solve(problem, np.random.default_rng(42))
    np.testing.assert_array_equal(a.controls, b.controls)
    assert np.all(np.abs(a.controls) <= problem.max_turn_rate[:, None] + 1e-12)
    assert a.generations == 25 and a.evaluations == 20 + 25 * 18
    # elitism: the best plan is at least as good as the best initial seed
    seeds = planner.initial_population(problem, np.random.default_rng(42), None)
    assert a.fitness >= evaluate(problem, seeds).fitness.max() - 1e-15


def test_warm_start_is_shifted_into_the_initial_population() -> None:
    problem = _problem()
    previous = np.array([[0.1, 0.2, -0.1, 0.0, 0.05], [0.0, 0.0, 0.1, 0.1, 0.1]])
    seeds = GeneticPlanner(population=20).initial_population(problem, np.random.default_rng(0), previous)
    np.testing.assert_allclose(seeds[0], shift_plan(previous))
    np.testing.assert_allclose(shift_plan(previous)[:, -1], previous[:, -1])


def test_anytime_deadline_returns_the_best_plan_so_far() -> None:
    ticks = itertools.count()
    fake_clock = lambda: 0.01 * next(ticks)  # noqa: E731  (10 ms per look)
    result = GeneticPlanner(population=20, generations=200, deadline_s=0.05).solve(
        _problem(), np.random.default_rng(1), now=fake_clock)
    assert result.generations < 200 and "deadline" in result.message
    assert result.success and np.isfinite(result.cost)


def test_stall_stops_early_when_nothing_improves() -> None:
    result = GeneticPlanner(population=20, generations=200, deadline_s=None, stall=5).solve(
        _problem(radius=None), np.random.default_rng(3))
    assert result.generations < 200 and "no improvement" in result.message


def _fly(planner, steps: int = 200, start=((1200.0, 1500.0), (1800.0, 1500.0))) -> tuple[np.ndarray, np.ndarray]:
    problem = _problem(radius=None, vehicles_xy=start)
    vehicles = problem.vehicles
    target = problem.target_means[0, :2]
    distances = []
    for _ in range(steps):
        current = replace(problem, vehicles=vehicles, target_means=np.tile(np.r_[target, 0.0, 0.0], (5, 1)))
        result = planner.solve(current)
        vehicles = step_vehicles(vehicles, result.controls[:, 0], 1.0, problem.max_turn_rate)
        distances.append(np.hypot(*(vehicles.xy - target).T))
    return np.array(distances), vehicles.xy


def test_orbit_baseline_settles_on_the_standoff_circle() -> None:
    distances, _ = _fly(OrbitPlanner(radius_m=300.0))
    np.testing.assert_allclose(distances[-50:], 300.0, atol=30.0)


def test_pursuit_baseline_closes_in_on_the_target() -> None:
    distances, _ = _fly(PursuitPlanner(), steps=100, start=((0.0, 500.0), (3000.0, 2500.0)))
    assert distances[-20:].max() < 2 * 125.0 + 10.0  # then circles it: turn radius v / eta = 125 m
    assert distances[0].min() > 1500.0
