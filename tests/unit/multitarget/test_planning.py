"""Planning for several tracks (:mod:`gcs.core.multitarget.planning`) against the step-by-step recursion."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget.planning import TargetsToPlan, plan_targets, targets_to_plan
from gcs.core.tracker import TrackerState


def test_the_horizon_predictions_are_eq_16_17_applied_step_by_step_and_the_weights_grow_with_the_unseen_time() -> None:
    motion = constant_velocity(2.0)
    rng = np.random.default_rng(4)
    means = rng.normal(0.0, 100.0, (3, 4))
    roots = rng.normal(0.0, 3.0, (3, 4, 4))
    covs = roots @ roots.transpose(0, 2, 1) + np.eye(4)
    planned = targets_to_plan(("t1", "t2", "t3"), means, covs, np.array([0.0, 20.0, 40.0]), motion, 1.0, 6, 20.0)
    f, q = motion.matrices(1.0)
    for k in range(3):
        x, p = means[k], covs[k]
        for j in range(6):  # x <- F x, P <- F P F^T + Q, one step at a time
            x, p = f @ x, f @ p @ f.T + q
            assert planned.means[k, j] == pytest.approx(x, abs=1e-9)
            assert planned.covs[k, j] == pytest.approx(p, rel=1e-9, abs=1e-9)
    assert planned.weights == pytest.approx(np.array([1.0, 2.0, 3.0]) / 6.0)  # 1 + u / tau, normalised


def test_targets_need_one_prediction_and_one_weight_each() -> None:
    with pytest.raises(ValueError, match="one prediction and one weight per target"):
        TargetsToPlan(("t1", "t2"), np.zeros((1, 5, 4)), np.zeros((2, 5, 4, 4)), np.array([0.5, 0.5]))


def test_a_planner_without_assignment_cannot_plan_several_targets() -> None:
    class OneTarget:
        def solve(self, *args, **kwargs):
            raise AssertionError("never asked")

    class Config:
        planner = OneTarget()

    targets = TargetsToPlan(("t1",), np.zeros((1, 5, 4)), np.zeros((1, 5, 4, 4)), np.array([1.0]))
    with pytest.raises(TypeError, match="cannot plan for several targets"):
        plan_targets(Config(), TrackerState(None, None, np.zeros(1)), None, targets, np.random.default_rng(0))


def test_without_predicting_ahead_each_estimate_is_held_over_the_horizon() -> None:
    means = np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0]])
    covs = np.stack([np.eye(4), 2.0 * np.eye(4)])
    held = targets_to_plan(("t1", "t2"), means, covs, np.zeros(2), constant_velocity(2.0), 1.0, 4, 20.0,
                           predict_ahead=False)
    assert held.means.shape == (2, 4, 4) and held.covs.shape == (2, 4, 4, 4)
    for j in range(4):
        np.testing.assert_array_equal(held.means[:, j], means)
        np.testing.assert_array_equal(held.covs[:, j], covs)
