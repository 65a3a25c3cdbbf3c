"""The sight objective (gcs.core.planners.sight), term by term on small cases worked by hand."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.kinematics import VehicleState
from gcs.core.models.sensor import SensorModel
from gcs.core.planners.airspace_guard import AirspaceGuard
from gcs.core.planners.problem import PlanningProblem
from gcs.core.planners.sight import VIOLATION_COST, SightModel, SightWeights, contribution, joint_values, sample_pattern
from gcs.core.world.airspace import RestrictedAirspace
from gcs.core.world.buildings import Buildings
from gcs.core.world.sight_table import HeightField, SightTable

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
# A 190 m wall from x = 990 to 1000 m; the target is 10 m east of it, at (1010, 1000).
WALL = Buildings.from_boxes([[990.0, 0.0, 1000.0, 2000.0]], [190.0])
TABLE = SightTable(HeightField.from_buildings(WALL, cell_m=2.0, margin_m=700.0), 200.0, reach_m=600.0)
T = 4


def _problem(xy, headings, weights_std: float = 0.1, guard: AirspaceGuard = AirspaceGuard(),
             path=None) -> PlanningProblem:
    """Vehicles at ``xy`` (200 m up, 25 m/s); the target held at (1010, 1000), or predicted along ``path`` (T, 2)."""
    count = len(xy)
    means = np.zeros((T, 4))
    means[:, :2] = (1010.0, 1000.0) if path is None else path
    covs = np.tile(np.diag([weights_std**2, weights_std**2, 1e-4, 1e-4]), (T, 1, 1))
    vehicles = VehicleState(np.array(xy, dtype=np.float64), np.array(headings, dtype=np.float64),
                            np.full(count, 25.0), np.full(count, 200.0))
    return PlanningProblem(vehicles, np.zeros(count), np.full(count, 0.2), 1.0, means, covs, [SENSOR] * count,
                           None, None, sight=TABLE, guard=guard, max_range_m=5000.0)


WEIGHTS = SightWeights(per_uav=0.5, information=0.0, standoff=0.0, turn_change=0.0, manoeuvre=0.0, samples=16)


def test_sample_pattern_has_the_moments_of_a_standard_normal() -> None:
    for count in (1, 5, 16, 32):
        z = sample_pattern(count)
        assert z.shape == (count, 2)
        assert np.allclose(z.mean(axis=0), 0.0, atol=1e-12)
        if count > 2:
            assert np.allclose(z.T @ z / count, np.eye(2), atol=1e-12)


def test_at_least_one_sees_and_each_uav_s_own_sight() -> None:
    # East of the wall a vehicle 100 m away sees the target; west of it (200 m away) it does not.
    east, west = ((1110.0, 1000.0), 0.0), ((810.0, 1000.0), 0.0)
    straight = np.zeros((1, 2, T))
    for team, seeing in (([east, west], 1), ([east, east], 2), ([west, west], 0)):
        problem = _problem([p for p, _ in team], [h for _, h in team])
        model = SightModel.build(problem, WEIGHTS)
        value = joint_values(model, straight)[0]
        # Straight flight east of the wall moves along x, away from the wall: still seen at every step.
        any_seen = T * (1 if seeing else 0)
        per_uav = WEIGHTS.per_uav / 2 * seeing * T
        assert value == pytest.approx(any_seen + per_uav), team


def test_the_information_term_is_a_bounded_share_of_the_variance() -> None:
    weights = SightWeights(per_uav=0.0, information=1.0, standoff=0.0, turn_change=0.0, manoeuvre=0.0)
    plans = np.zeros((1, 1, T))
    # The vehicle flies north from (1010, 975); the target is predicted right below it, 50 m east or 400 m east.
    flown = np.stack([np.full(T, 1010.0), 975.0 + 25.0 * np.arange(1, T + 1)], axis=1)
    gains = {}
    for name, east in (("above", 0.001), ("near", 50.0), ("far", 400.0)):
        # With the target 5 m uncertain and seen at every step, each step is worth 1 plus the share removed.
        problem = _problem([(1010.0, 975.0)], [np.pi / 2], weights_std=5.0, path=flown + (east, 0.0))
        value = joint_values(SightModel.build(problem, weights), plans)[0]
        gains[name] = (value - T) / T
        assert 0.0 <= gains[name] < 1.0, (name, gains[name])
    # Straight above the mean the azimuth says nothing (second-order R): less than from 50 m, and no blow-up.
    assert gains["above"] < gains["near"]
    assert gains["far"] < gains["near"]


def test_stand_off_shaping_is_worth_less_than_one_seen_step() -> None:
    weights = SightWeights(per_uav=0.0, information=0.0, standoff=0.9, standoff_m=100.0, standoff_scale_m=150.0,
                           turn_change=0.0, manoeuvre=0.0)
    # Two blind vehicles west of the wall, at 310 m and 110 m from the target, flying away (west).
    problem = _problem([(700.0, 1000.0), (900.0, 1000.0)], [np.pi, np.pi])
    value = joint_values(SightModel.build(problem, weights), np.zeros((1, 2, T)))[0]
    ends = np.array([700.0, 900.0]) - 25.0 * T  # their distances to the target at the last step
    distance = 1010.0 - ends
    expected = sum(0.9 / 2 * 150.0 / (150.0 + abs(d - 100.0)) for d in distance)
    assert value == pytest.approx(expected)
    assert value < 1.0  # at most 0.9 whatever the team does


def test_turn_changes_are_charged_per_full_rate_change() -> None:
    weights = SightWeights(per_uav=0.0, information=0.0, standoff=0.0, turn_change=0.1, manoeuvre=0.0)
    problem = _problem([(1110.0, 1000.0)], [0.0])
    model = SightModel.build(problem, weights)
    zigzag = np.array([[[0.2, -0.2, 0.2, 0.0]]])  # changes of 1, 2, 2 and 1 full rates from the 0 flown now
    straight = np.zeros((1, 1, T))
    values = joint_values(model, np.concatenate([straight, zigzag]))
    assert values[0] - values[1] == pytest.approx(0.1 * 6.0, abs=0.1 * T)  # the zigzag may also lose sight
    seen_zigzag = contribution(model, 0, zigzag[:, 0]).seen.sum()
    assert values[1] == pytest.approx(seen_zigzag - 0.6)  # the any term is its own sight here


def test_restricted_airspace_costs_more_than_any_plan_can_gain() -> None:
    zone = RestrictedAirspace.from_zones([([[1150.0, 900.0], [1300.0, 900.0], [1300.0, 1100.0], [1150.0, 1100.0]],
                                           0.0, 1000.0)])
    guard = AirspaceGuard(zone, margin_m=25.0)
    # From 100 m west of the zone, straight east: 1125 m (within the margin), 1150 m (inside), no way out.
    near = contribution(SightModel.build(_problem([(1050.0, 1000.0)], [0.0], guard=guard), WEIGHTS), 0,
                        np.zeros((1, T)))
    assert near.own[0] < -3 * VIOLATION_COST + 10.0
    # From 200 m west: straight east stays clear but ends with both loiter circles cut by the zone (one
    # violation); turning left at full rate ends with the left circle clear.
    far = SightModel.build(_problem([(950.0, 1000.0)], [0.0], guard=guard), WEIGHTS)
    straight, left = contribution(far, 0, np.zeros((1, T))), contribution(far, 0, np.full((1, T), 0.2))
    assert -VIOLATION_COST - 10.0 < straight.own[0] < -VIOLATION_COST + 10.0
    assert left.own[0] > -10.0
