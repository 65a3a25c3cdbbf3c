"""UAVs shared between targets: the sight objective over several targets, and the assignment alternative.

**Summed objective.** With K tracked targets, each with its own horizon prediction
(a :class:`~gcs.core.planners.problem.PlanningProblem` per target that differs only
in ``target_means`` and ``target_covs``), the team plan maximises

.. math:: J = \\sum_k w_k J_k, \\qquad \\sum_k w_k = 1,

with ``J_k`` the single-target sight objective of :mod:`gcs.core.planners.sight`
(seen steps of target k, its information and the per-UAV, stand-off and turn terms).
The turn and airspace terms of ``J_k`` do not depend on k, so with weights that sum
to 1 they count once; the stand-off pull becomes the weighted mean of the pulls
toward each target's ring. One UAV may serve several targets at once (a street seen
from one place), and a second UAV goes where the weighted gain is largest.

**Priorities against starvation.** A target that no UAV sees for a while must win
a UAV back. The weights are

.. math:: w_k \\propto p_k \\, (1 + u_k / \\tau),

with ``p_k`` the target's priority, ``u_k`` the seconds since its track last had a
detection and ``tau`` (``starvation_s``) the time in which an unseen target's claim
doubles: the claim grows linearly with the age of the information, as in
age-of-information scheduling, until sending a UAV to it pays more than what the
UAV gives where it is.

**Assignment alternative** (:func:`assign_vehicles`). Each UAV is given one target by
a linear assignment (scipy's ``linear_sum_assignment``) on the cost
``c_ik = d_ik / w_k`` (``d_ik`` the horizontal distance from UAV i to target k's
current predicted position; with fewer targets than UAVs the targets are repeated,
each repeat costing ``max c_ik`` more, so that no target gets a second UAV before every
target has one), and every target is then planned for with its own UAVs alone.
Targets beyond the number of UAVs get no UAV in that decision step.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from gcs.core.kinematics import VehicleState
from gcs.core.planners.problem import PlanningProblem
from gcs.core.planners.sight import Contribution, SightModel, TeamView, joint_values

__all__ = ["target_weights", "SharedView", "shared_joint_values", "assign_vehicles", "vehicles_subproblem"]


def target_weights(priorities: ArrayLike, unseen_s: ArrayLike, starvation_s: float) -> NDArray[np.float64]:
    """``w_k = p_k (1 + u_k / tau) / sum_l p_l (1 + u_l / tau)`` (module docstring), shape (K,)."""
    p = np.asarray(priorities, dtype=np.float64)
    u = np.asarray(unseen_s, dtype=np.float64)
    if p.shape != u.shape or p.ndim != 1 or p.size == 0:
        raise ValueError(f"one priority and one unseen time per target, got {p.shape} and {u.shape}")
    if not (np.all(p > 0.0) and np.all(u >= 0.0) and starvation_s > 0.0):
        raise ValueError("priorities must be > 0, unseen times >= 0 and starvation_s > 0")
    claim = p * (1.0 + u / starvation_s)
    shares: NDArray[np.float64] = claim / claim.sum()
    return shares


class SharedView:
    """The team's current plan against K targets: one :class:`~gcs.core.planners.sight.TeamView` per target.

    Same interface as ``TeamView`` (``controls``, :meth:`values`, :meth:`accept`), so the
    per-vehicle search of :mod:`gcs.core.planners.sequential` runs on either.
    """

    def __init__(self, models: Sequence[SightModel], weights: NDArray[np.float64],
                 controls: NDArray[np.float64]) -> None:
        if len(models) != len(weights) or not models:
            raise ValueError("one weight per target model, and at least one target")
        self.views = [TeamView(model, controls) for model in models]
        self.weights = np.asarray(weights, dtype=np.float64)

    @property
    def controls(self) -> NDArray[np.float64]:
        return self.views[0].controls

    def values(self, vehicle: int, candidates: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                                             list[Contribution]]:
        """``J`` of the team with ``vehicle`` flying each candidate (C, T): values (C,) and each target's terms."""
        scored = [view.values(vehicle, candidates) for view in self.views]
        return _weighted_sum(self.weights, [value for value, _ in scored]), [part for _, part in scored]

    def accept(self, vehicle: int, candidates: NDArray[np.float64], parts: list[Contribution], index: int) -> None:
        for view, part in zip(self.views, parts):
            view.accept(vehicle, candidates, part, index)

    def seen_steps(self) -> float:
        """Expected vehicle-steps from which a target is seen, summed over the targets."""
        return sum(float(p.seen.sum()) for view in self.views for p in view.parts)


def shared_joint_values(models: Sequence[SightModel], weights: NDArray[np.float64],
                        plans: NDArray[np.float64]) -> NDArray[np.float64]:
    """``J`` of whole-team plans (P, V, T) against every target: (P,)."""
    return _weighted_sum(weights, [joint_values(model, plans) for model in models])


def _weighted_sum(weights: NDArray[np.float64], values: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    """``sum_k w_k values_k``, added in order from the first (one target, weight 1: its values exactly)."""
    total: NDArray[np.float64] = weights[0] * values[0]
    for weight, value in zip(weights[1:], values[1:]):
        total = total + weight * value
    return total


def assign_vehicles(vehicles: VehicleState, target_xy: NDArray[np.float64],
                    weights: NDArray[np.float64]) -> NDArray[np.int64]:
    """The target of each vehicle (V,), by the assignment of the module docstring."""
    v, k = len(vehicles), len(target_xy)
    offsets = vehicles.xy[:, None, :] - target_xy[None, :, :]
    base = np.hypot(offsets[..., 0], offsets[..., 1]) / np.asarray(weights)[None, :]  # (V, K)
    repeats = -(-v // k)
    cost = np.concatenate([base + r * (base.max() + 1.0) for r in range(repeats)], axis=1)
    rows, cols = linear_sum_assignment(cost)
    assigned = np.empty(v, dtype=np.int64)
    assigned[rows] = cols % k
    return assigned


def vehicles_subproblem(problem: PlanningProblem, indices: Sequence[int] | NDArray[np.intp]) -> PlanningProblem:
    """``problem`` for the vehicles ``indices`` alone (the sight objective only: no visibility regions)."""
    idx = np.asarray(indices, dtype=np.int64)
    vehicles = problem.vehicles
    team = VehicleState(vehicles.xy[idx], vehicles.heading[idx], vehicles.speed[idx], vehicles.altitude[idx])
    return replace(problem, vehicles=team, current_turn_rate=problem.current_turn_rate[idx],
                   max_turn_rate=problem.max_turn_rate[idx], sensors=[problem.sensors[i] for i in idx],
                   visibility=None)
