"""Planning for several tracks at once: each track's horizon prediction, its claim on the UAVs, one team plan.

For every confirmed track ``k`` (and every lost target still searched for,
:class:`~gcs.core.multitarget.lost.LostTargets`) with estimate ``(x_k, P_k)`` the
k+1..k+n prediction of the constant-velocity model is, j steps ahead,

.. math:: x_{k+j} = F^j x_k, \\qquad P_{k+j} = F^j P_k (F^j)^T + Q_j

(wang2012 eq. 16-17, carried j steps at once by
:meth:`~gcs.core.models.motion.LinearMotionModel.horizon_matrices`). Each target then
has the single-target planning problem of the team against its own prediction, and its
weight ``w_k = (1 + u_k / tau) / sum_l (1 + u_l / tau)`` grows with the seconds ``u_k``
it has gone without a detection (:func:`gcs.core.planners.shared.target_weights`), so
that no target is starved. The team plan is made by assignment: each UAV is given one
target, and each target is planned for with its own UAVs
(:meth:`gcs.core.planners.sequential.SightPlanner.solve_assigned`; ``gcs-bench
sharing`` measured it against the summed objective and chose it). Like
:func:`gcs.core.tracker.plan`, the plan is then kept out of restricted airspace by the
guard, and its first turn rates are flown.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.kinematics import VehicleState
from gcs.core.models.motion import LinearMotionModel
from gcs.core.planners.problem import PlanningProblem, PlanResult, SharingPlanner
from gcs.core.planners.shared import target_weights
from gcs.core.tracker import TrackerConfig, TrackerState

__all__ = ["TargetsToPlan", "targets_to_plan", "problems_for", "plan_targets", "plans_targets"]


@dataclass(frozen=True, eq=False)
class TargetsToPlan:
    """K targets to plan for: ids (K,), predictions over the horizon (K, n, 4) and (K, n, 4, 4), weights (K,)."""

    ids: tuple[str, ...]
    means: NDArray[np.float64]
    covs: NDArray[np.float64]
    weights: NDArray[np.float64]

    def __post_init__(self) -> None:
        k = len(self.ids)
        if k == 0 or self.means.shape[0] != k or self.covs.shape[0] != k or self.weights.shape != (k,):
            raise ValueError(f"one prediction and one weight per target, got {k} ids, means {self.means.shape}, "
                             f"covs {self.covs.shape}, weights {self.weights.shape}")


def targets_to_plan(ids: tuple[str, ...], means: NDArray[np.float64], covs: NDArray[np.float64],
                    unseen_s: NDArray[np.float64], motion: LinearMotionModel, step_s: float, horizon_steps: int,
                    starvation_s: float, predict_ahead: bool = True) -> TargetsToPlan:
    """The targets' horizon predictions (module docstring) from their estimates (K, 4), (K, 4, 4), and their weights;
    ``predict_ahead`` False holds each estimate over the horizon (wang2012's k+0 comparison)."""
    if not predict_ahead:
        return TargetsToPlan(tuple(ids), np.repeat(means[:, None], horizon_steps, axis=1),
                             np.repeat(covs[:, None], horizon_steps, axis=1),
                             target_weights(np.ones(len(ids)), unseen_s, starvation_s))
    f_j, q_j = motion.horizon_matrices(step_s, horizon_steps)
    predicted_means = np.einsum("tab,kb->kta", f_j, means)  # wang2012 eq. (16)-(17): x_{k+j} = F^j x_k
    predicted_covs = np.einsum("tab,kbc,tdc->ktad", f_j, covs, f_j) + q_j[None]  # P_{k+j} = F^j P_k F^jT + Q_j
    return TargetsToPlan(tuple(ids), predicted_means, predicted_covs,
                         target_weights(np.ones(len(ids)), unseen_s, starvation_s))


def problems_for(config: TrackerConfig, vehicles: VehicleState, turn_rate: NDArray[np.float64],
                 means: NDArray[np.float64], covs: NDArray[np.float64]) -> list[PlanningProblem]:
    """One planning problem per target (K, n, 4) / (K, n, 4, 4), beside the same team ``vehicles``."""
    problems = []
    for mean, cov in zip(means, covs):
        visibility = None if config.visibility is None else config.visibility(mean[:, :2])
        problems.append(PlanningProblem(vehicles, turn_rate, config.max_turn_rate, config.step_s, mean, cov,
                                        config.sensors, visibility, config.restricted, config.weights, config.sight,
                                        config.guard, config.max_range_m))
    return problems


def plans_targets(config: TrackerConfig) -> bool:
    """Whether the tracker's planner can share the UAVs between targets (it has ``solve_assigned``)."""
    return isinstance(config.planner, SharingPlanner)


def plan_targets(config: TrackerConfig, state: TrackerState, vehicles: VehicleState, targets: TargetsToPlan,
                 rng: np.random.Generator, now: Callable[[], float] | None = None,
                 ) -> tuple[TrackerState, NDArray[np.float64], PlanResult]:
    """The team plan for several targets (module docstring): the new state (its plan the warm start of the
    next), the first turn rates (V,) and the planner's result."""
    planner = config.planner
    if not isinstance(planner, SharingPlanner):
        raise TypeError(f"{type(planner).__name__} cannot plan for several targets (no solve_assigned)")
    problems = problems_for(config, vehicles, state.turn_rate, targets.means, targets.covs)
    result = planner.solve_assigned(problems, targets.weights, rng, state.plan, now)
    safe = config.guard.safe(vehicles, result.controls, config.step_s, config.max_turn_rate)
    if safe is not result.controls:
        result = replace(result, controls=safe, message=f"{result.message}; airspace fallback")
    turn_rate = result.controls[:, 0].copy()
    return TrackerState(state.estimate, result.controls, turn_rate), turn_rate, result
