"""The CV + coordinated-turn IMM target filter (estimator kind ``imm``)."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gcs.config import ScenarioError, validate_scenario
from gcs.core.filters.imm_target import ImmEstimate, ImmTargetFilter, coordinated_turn
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection, TrackerConfig, fuse
from gcs.scenarios import load_scenario
from gcs.engine.tracker_factory import tracker_config
from sim_vehicles.truth.sensor import exact_measurements

SENSOR = SensorModel.range_bearing(10.0, 0.05, 0.05)
NS = 1_000_000_000


def test_coordinated_turn_is_the_exact_solution_and_cv_at_zero_rate() -> None:
    state = np.array([100.0, -50.0, 8.0, 3.0, 0.2])

    def ode(_t, s):
        return [s[2], s[3], -s[4] * s[3], s[4] * s[2], 0.0]

    exact = solve_ivp(ode, (0.0, 2.5), state, rtol=1e-11, atol=1e-11).y[:, -1]
    np.testing.assert_allclose(coordinated_turn(state, 2.5), exact, rtol=1e-8, atol=1e-8)
    straight = state.copy()
    straight[4] = 0.0
    np.testing.assert_allclose(coordinated_turn(straight, 2.5), [120.0, -42.5, 8.0, 3.0, 0.0])


def _vehicles(k: int, centre: np.ndarray) -> np.ndarray:
    angles = 2.0 * np.pi * np.arange(3) / 3 + 0.08 * k
    return np.column_stack([centre[0] + 300 * np.cos(angles), centre[1] + 300 * np.sin(angles), [200.0, 210.0, 220.0]])


def test_imm_with_the_turn_mode_switched_off_is_the_duif() -> None:
    q = 0.3
    off = ImmTargetFilter(cv_accel_psd_m2_s3=q, transition=((1.0, 0.0), (1.0, 0.0)), initial_probabilities=(1.0, 0.0))
    duif = TrackerConfig(uif=UnscentedInformationFilter(constant_velocity(q)), sensors=(SENSOR,) * 3, planner=None,
                         max_turn_rate=np.zeros(3))
    imm = TrackerConfig(uif=duif.uif, sensors=duif.sensors, planner=None, max_turn_rate=np.zeros(3), target_imm=off)
    rng = np.random.default_rng(1)
    a = b = GaussianEstimate(np.array([1500.0, 1500.0, 0.0, 0.0]), np.diag([900.0, 900.0, 100.0, 100.0]), 0)
    truth = np.array([1510.0, 1490.0, 4.0, -2.0])
    for k in range(1, 25):
        truth = truth + [truth[2], truth[3], 0.0, 0.0]
        xyz = _vehicles(k, truth)
        z = exact_measurements(np.append(truth[:2], 0.0), xyz) + rng.normal(size=(3, 3)) * SENSOR.std
        detections = [Detection(i, xyz[i], z[i]) for i in range(3) if k % 4 or i]  # some steps miss one
        a, b = fuse(duif, a, k * NS, detections), fuse(imm, b, k * NS, detections)
    assert isinstance(b, ImmEstimate) and b.probabilities[0] == 1.0
    np.testing.assert_allclose(b.mean, a.mean, rtol=1e-10)
    np.testing.assert_allclose(b.cov, a.cov, rtol=1e-8)


def _turning_run(config: TrackerConfig, seed: int) -> tuple[np.ndarray, list]:
    """A target driving 20 s straight, then a 0.15 rad/s circle for 30 s: errors (50,) and estimates."""
    rng = np.random.default_rng(seed)
    state, estimate, errors, estimates = np.array([1500.0, 1500.0, 10.0, 0.0, 0.0]), None, [], []
    for k in range(50):
        if k > 0:
            state[4] = 0.15 if k > 20 else 0.0
            state = coordinated_turn(state, 1.0)
        xyz = _vehicles(k, state)
        z = exact_measurements(np.append(state[:2], 0.0), xyz) + rng.normal(size=(3, 3)) * SENSOR.std
        estimate = fuse(config, estimate, k * NS, [Detection(i, xyz[i], z[i]) for i in range(3)])
        errors.append(np.hypot(*(estimate.mean[:2] - state[:2])))
        estimates.append(estimate)
    return np.array(errors), estimates


def test_the_turn_mode_takes_over_in_a_turn_and_tracks_it_better() -> None:
    scenario = load_scenario("wang2012_urban")
    imm = tracker_config(msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(
        scenario.estimator, kind="imm", accel_psd_m2_s3=0.05)), None, "orbit")
    cv = tracker_config(msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(
        scenario.estimator, accel_psd_m2_s3=0.05)), None, "orbit")
    for seed in (3, 4):
        imm_errors, estimates = _turning_run(imm, seed)
        cv_errors, _ = _turning_run(cv, seed)
        p_turn = np.array([e.probabilities[1] for e in estimates])
        assert p_turn[30:].mean() > p_turn[5:20].mean() + 0.1  # more weight on the turn model in the turn
        # The quiet CV model alone lags the turn by tens of metres; the IMM follows it.
        assert np.sqrt(np.mean(imm_errors[30:] ** 2)) < 0.4 * np.sqrt(np.mean(cv_errors[30:] ** 2))


def test_imm_needs_the_cv2d_layout_and_refuses_time_going_back() -> None:
    scenario = load_scenario("wang2012_urban")
    bad = msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(scenario.estimator, kind="imm", model="ca2d"))
    with pytest.raises(ScenarioError, match="estimator.model"):
        validate_scenario(bad)
    f = ImmTargetFilter()
    start = f.start(GaussianEstimate(np.zeros(4), np.eye(4), 5 * NS))
    with pytest.raises(ValueError, match="backwards"):
        f.step(start, 4 * NS, [])
    with pytest.raises(AssertionError, match="row-stochastic"):
        ImmTargetFilter(transition=((0.9, 0.2), (0.1, 0.9)))
    assert math.isclose(start.modes.covs[0, 4, 4], 0.3**2)
