"""RHC cost (wang2012 eq. 20-29): each term against hand computation and the filter's eq. (18)."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.filters.prediction import expected_information, predict_horizon
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.kinematics import VehicleState
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.planners import PlanningProblem, RhcWeights, evaluate

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
UIF = UnscentedInformationFilter(constant_velocity(1.96))


class Discs:
    """Visibility regions: a disc around each predicted point (stand-in for the city's maps)."""

    def __init__(self, centres: np.ndarray, radius: float) -> None:
        self.centres, self.radius = centres, radius

    def visible(self, xy: np.ndarray) -> np.ndarray:
        d = xy - self.centres
        return np.hypot(d[..., 0], d[..., 1]) < self.radius


def _problem(radius: float | None = 600.0, weights: RhcWeights = RhcWeights(), restricted=None,
             vehicles_xy=((1200.0, 1500.0), (1800.0, 1500.0)), headings=(0.0, np.pi)) -> PlanningProblem:
    posterior = GaussianEstimate(np.array([1500.0, 1500.0, 5.0, 0.0]), np.diag([25.0, 25.0, 4.0, 4.0]), 0)
    prediction = predict_horizon(UIF, posterior, 1.0, 5)
    vehicles = VehicleState(np.array(vehicles_xy), np.array(headings),
                            np.array([25.0, 25.0]), np.array([200.0, 210.0]))
    visibility = None if radius is None else Discs(prediction.positions, radius)
    return PlanningProblem(vehicles, np.zeros(2), np.array([0.2, 0.2]), 1.0, prediction.states.mean,
                           prediction.states.cov, [SENSOR, SENSOR], visibility, restricted, weights)


def test_closed_form_fisher_information_equals_jacobian_form() -> None:
    rng = np.random.default_rng(1)
    targets = rng.uniform(0, 3000, (50, 2))
    vehicles = np.column_stack([rng.uniform(0, 3000, (50, 2)), rng.uniform(100, 300, 50)])
    for sensor in (SENSOR, SensorModel.bearing_only(0.02), SensorModel.bearing_only(0.02, 0.03),
                   SensorModel.bearing_only(0.02, distance_dependent=True, reference_range_m=500.0)):
        jac = sensor.jacobian(targets, vehicles, 2)
        r_inv = sensor.noise_information(None, targets, vehicles)
        expected = jac.swapaxes(-1, -2) @ (jac * np.asarray(r_inv)[..., None])
        xx, xy, yy = sensor.fisher_information_xy(targets, vehicles)
        np.testing.assert_allclose(np.stack([xx, xy, yy], -1), expected[:, [0, 0, 1], [0, 1, 1]], rtol=1e-9)


def test_planner_information_is_close_to_the_unscented_eq18() -> None:
    problem = _problem()
    prediction = predict_horizon(UIF, GaussianEstimate(np.array([1500.0, 1500.0, 5.0, 0.0]),
                                                       np.diag([25.0, 25.0, 4.0, 4.0]), 0), 1.0, 5)
    candidates = np.array([[[1200.0 + 30 * j, 1500.0, 200.0] for j in range(5)]])
    ut = expected_information(UIF, prediction, SENSOR, candidates)[0]
    xx, xy, yy = SENSOR.fisher_information_xy(problem.target_means[:, :2], candidates[0])
    analytic = np.stack([np.stack([xx, xy], -1), np.stack([xy, yy], -1)], -2)
    np.testing.assert_allclose(analytic, ut, rtol=0.02, atol=1e-6)


def test_control_cost_follows_eq23_eq24() -> None:
    weights = RhcWeights(u_max_rad_s=0.1, w_u=10.0, control_weight=1.0)
    problem = _problem(weights=weights)
    plan = np.array([[0.05, 0.05, 0.05, 0.05, 0.05], [0.2, -0.2, -0.2, -0.2, -0.2]])
    cost = evaluate(problem, plan[None])
    # vehicle 1: |u| sums to 0.25, one change of 0.05 -> 0.30; vehicle 2: |u| sums to 1.0,
    # a first change of 0.2 > U_max and one of 0.4 -> W_u twice -> 21.0.
    assert cost.j_u[0] == pytest.approx(0.30 + 21.0)


def test_restricted_airspace_costs_w_res_per_vehicle_step() -> None:
    zone = lambda xyz: xyz[..., 0] > 1700.0  # noqa: E731
    problem = _problem(weights=RhcWeights(w_res=1000.0), restricted=zone)
    straight = np.zeros((1, 2, 5))
    cost = evaluate(problem, straight)
    # Vehicle 2 flies west from x = 1800 at 25 m/s: 1775, 1750, 1725 are inside, 1700, 1675 are not.
    assert cost.j_safe[0] == pytest.approx(3000.0)


def test_being_seen_lowers_the_information_cost() -> None:
    far = _problem(radius=100.0)  # nobody inside the visibility discs
    near = _problem(radius=5000.0)  # everybody inside
    plan = np.zeros((1, 2, 5))
    blind, seen = evaluate(far, plan), evaluate(near, plan)
    assert not blind.visible.any() and seen.visible.all()
    assert seen.j_in[0] < blind.j_in[0]
    assert blind.f_dis[0] > 0 and seen.f_dis[0] == 0


def test_standoff_term_prefers_plans_near_the_standoff_distance() -> None:
    weights = RhcWeights(standoff_m=300.0)
    start = ((1050.0, 1500.0), (1950.0, 1500.0))  # 450 m from the target, both sides
    toward = _problem(radius=10.0, weights=weights, vehicles_xy=start, headings=(0.0, np.pi))
    away = _problem(radius=10.0, weights=weights, vehicles_xy=start, headings=(np.pi, 0.0))
    plan = np.zeros((1, 2, 5))
    assert evaluate(toward, plan).f_dis[0] > 2 * evaluate(away, plan).f_dis[0]


def test_w_vis_credits_each_hidden_vehicle_step_with_w_vis_times_identity() -> None:
    plan = np.zeros((1, 2, 5))
    blind = evaluate(_problem(radius=100.0), plan)
    credited = evaluate(_problem(radius=100.0, weights=RhcWeights(w_vis=0.01)), plan)
    prior = _problem().prior_information
    # 2 vehicles x 5 steps hidden: the information is the prior plus 10 * 0.01 * I_2 (eq. 22).
    expected = np.trace(np.linalg.inv(prior + 10 * 0.01 * np.eye(2)))
    assert credited.j_in[0] == pytest.approx(expected)
    assert credited.j_in[0] < blind.j_in[0]
