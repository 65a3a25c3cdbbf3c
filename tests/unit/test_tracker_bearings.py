"""The tracker with bearing-only sensors: zuo2021's ML start and VG-UKF in place of the DUIF."""

from __future__ import annotations

import numpy as np

from gcs.core.tracker import Detection, fuse
from gcs.scenarios import load_scenario
from gcs.engine.tracker_factory import tracker_config
from sim_vehicles.truth.sensor import TargetSensor

SCENARIO = load_scenario("zuo2021_aoa")
S = 1_000_000_000


def test_bearing_only_scenario_fuses_with_ml_start_and_vgukf() -> None:
    config = tracker_config(SCENARIO, world=None, planner="ga_k5")
    assert config.bearing_filter is not None and config.sensors[0].components == ("azimuth",)
    truth = TargetSensor.from_config(SCENARIO.sensor)
    rng = np.random.default_rng(8)
    target = np.array([10000.0, 5000.0, 0.0])
    vehicles = np.array([[v.start_enu_m[0], v.start_enu_m[1], v.altitude_m] for v in SCENARIO.vehicles])

    def scan(k: int, count: int) -> list[Detection]:
        moved = vehicles + np.array([40.0 * k, 0.0, 0.0])  # flying east, toward the target
        observed = truth.observe(target, moved[:count], None, rng)
        return [Detection(i, moved[i], observed.values[i]) for i in range(count)]

    assert fuse(config, None, 0, scan(0, 1)) is None  # one bearing fixes no position
    estimate = fuse(config, None, 0, scan(0, 3))
    first_error = np.hypot(*(estimate.mean[:2] - target[:2]))
    for k in range(1, 60):
        estimate = fuse(config, estimate, k * S, scan(k, 3))
    assert estimate.stamp_ns == 59 * S
    error = np.hypot(*(estimate.mean[:2] - target[:2]))
    assert error < 0.5 * first_error and error < 1500.0
    std = np.sqrt(np.linalg.eigvalsh(estimate.cov[:2, :2]).max())
    assert error < 4.0 * std  # the covariance is not wildly overconfident


def test_the_scenarios_gcrlb_lm_planner_plans_through_the_tracker_within_the_turn_limit() -> None:
    from gcs.core.filters.uif import GaussianEstimate
    from gcs.core.kinematics import VehicleState
    from gcs.core.planners import OneStepHeadingPlanner
    from gcs.core.tracker import TrackerState, plan

    config = tracker_config(SCENARIO, world=None, planner="gcrlb_lm")
    assert isinstance(config.planner, OneStepHeadingPlanner)
    vehicles = VehicleState(np.array([[1000.0, 3000.0], [2000.0, 2000.0], [1000.0, 1000.0]]), np.zeros(3),
                            np.full(3, 40.0), np.array([100.0, 110.0, 120.0]))
    estimate = GaussianEstimate(np.array([10000.0, 5000.0, -4.0, 3.0]), np.diag([4e5, 4e5, 25.0, 25.0]), 0)
    state, turn_rate, diagnostics = plan(config, TrackerState(estimate, None, np.zeros(3)), vehicles,
                                         np.random.default_rng(0))
    limit = np.array([v.max_turn_rate_rad_s for v in SCENARIO.vehicles])
    assert state.plan.shape == (3, SCENARIO.planner.horizon_steps)
    assert np.all(np.abs(turn_rate) <= limit + 1e-12)
    assert diagnostics.plan.success and diagnostics.plan.cost > 0
    straight = tracker_config(SCENARIO, world=None, planner="straight").planner.solve(
        _problem(config, estimate, vehicles), np.random.default_rng(0))
    assert diagnostics.plan.cost <= straight.cost * (1 + 1e-6)  # tr(GCRLB) at k+1: LM at least as good (to ftol)


def _problem(config, estimate, vehicles):
    from gcs.core.planners import PlanningProblem
    from gcs.core.tracker import prediction

    predicted = prediction(config, estimate)
    return PlanningProblem(vehicles=vehicles, current_turn_rate=np.zeros(3), max_turn_rate=config.max_turn_rate,
                           step_s=config.step_s, target_means=predicted.states.mean, target_covs=predicted.states.cov,
                           sensors=config.sensors, visibility=None, restricted=None, weights=config.weights)
