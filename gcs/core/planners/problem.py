"""The receding-horizon planning problem of wang2012 section 4.1 and its cost (eq. 20-29).

A plan is a ``V x T`` matrix of turn-rate commands (eq. 27); a population of
plans is an array (P, V, T). :func:`evaluate` scores a whole population in one
vectorised pass:

* roll every plan out with the kinematics of eq. (1);
* visibility ``d_ij``: vehicle i at step j lies in the target's visibility
  region ``X^{hV}(x[j]^-)`` of the predicted target point (eq. 22's condition),
  given by one precomputed map per horizon step (``h`` = the lowest vehicle's
  altitude, as the paper does);
* information (eq. 21-22): ``Y = sum_j [Y^-[j] + sum_i I_i[j]]`` over the
  position block, with ``I_i[j]`` the expected information of a detection
  from the planned position (eq. 18) when visible and ``W_vis I_2`` when not,
  and ``J_in = tr(Y^-1)`` (the paper writes the matrix inverse; its trace, the
  mean squared error it implies, is the scalar we minimise);
* control (eq. 23-24): ``J_u = w_c sum_j sum_i (|u_i[j]| + LosC(u_i[j], u_i[j-1]))``
  with ``LosC = |du|`` up to ``U_max`` and ``W_u`` beyond; ``u_i[0]`` is the
  command being flown now;
* safety (eq. 25-26): ``J_safe = sum_j sum_i W_res [x_i[j] in restricted airspace]``;
* fitness (eq. 28-29): ``f = 1 / J_rhc + f_dis`` with ``J_rhc = J_in + J_u + J_safe``
  and the stand-off term ``f_dis = w_d / sum_{i blind} sum_j |dis(x[j]^-, x_i[j]) - d_r|``
  over the vehicles that see the target at no step of the plan. The paper applies
  it when no vehicle sees it ("J_in = 0", no information gain), pulling the team
  to the stand-off distance ``d_r``; we apply it to every blind vehicle, which is
  the paper's term when all are blind, so that one vehicle that has lost the
  target is pulled back while the others keep tracking (otherwise nothing in
  the cost steers it: outside every visibility region its information is
  ``W_vis`` wherever it flies).

Planner information (eq. 18). For speed the planner uses the Fisher
information of a detection at the predicted mean, ``H^T R^-1 H`` with the
analytic Jacobian ``H`` of eq. (4), the limit of eq. (18)'s unscented
``(H^p)^T R^-1 H^p`` when the prediction's spread is small against the range;
``tests/unit/test_planner_cost.py`` checks the two agree for typical
predictions.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from gcs.core.kinematics import VehicleState, rollout
from gcs.core.models.sensor import SensorModel
from gcs.core.planners.airspace_guard import AirspaceGuard
from gcs.core.world.sight_table import SightTable

__all__ = ["Visibility", "RhcWeights", "PlanningProblem", "CostBreakdown", "PlanResult", "Planner", "SharingPlanner",
           "evaluate"]


class Visibility(Protocol):
    """Visibility regions of the T predicted target points (wang2012 X^{hV}(x[j]), eq. 22)."""

    def visible(self, vehicle_xy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """For positions (..., T, 2), True where a vehicle at step j would see predicted point j."""


@dataclass(frozen=True)
class RhcWeights:
    """Weights of the RHC cost (wang2012 eq. 22-29) and our two scale factors.

    ``w_vis``: information credited for an occluded step (eq. 22); ``u_max_rad_s`` and
    ``w_u``: smoothness threshold and penalty (eq. 24); ``w_res``: restricted-airspace
    penalty (eq. 26); ``standoff_m``: ``d_r`` of eq. (29). ``control_weight`` scales
    ``J_u`` against ``J_in`` (the paper adds them unscaled although their units
    differ) and ``standoff_weight`` is the numerator of ``f_dis``.
    """

    w_vis: float = 0.0
    u_max_rad_s: float = 0.1
    w_u: float = 10.0
    w_res: float = 1e6
    standoff_m: float = 300.0
    control_weight: float = 1.0
    standoff_weight: float = 1.0


@dataclass(frozen=True)
class PlanningProblem:
    """Everything a planner needs at decision step k; pure data.

    Attributes
    ----------
    vehicles : VehicleState
        The V vehicles now.
    current_turn_rate : ndarray (V,)
        Command being flown now, ``u_i[k]`` of eq. (24).
    max_turn_rate : ndarray (V,)
        ``eta_max`` of eq. (1) and (27), rad/s.
    step_s : float
        Decision step, seconds.
    target_means : ndarray (T, n)
        Predicted target states at k+1..k+T (eq. 16-17); T is the horizon.
    target_covs : ndarray (T, n, n)
        Their covariances.
    sensors : sequence of SensorModel, length V
    visibility : Visibility or None
        Visibility regions of the T predicted points; None means an open field.
    restricted : callable (xyz (..., 3) -> bool (...)) or None
        Restricted airspace test (eq. 5); None means none.
    weights : RhcWeights
    sight : SightTable or None
        Where ground points can be seen from, for the sight objective
        (:mod:`gcs.core.planners.sight`); None: open field is not supported there.
    guard : AirspaceGuard
        Restricted airspace as a hard constraint (every planner's plan passes it).
    max_range_m : float
        The sensors' range (3-D), metres, for the sight objective.
    target_samples : ndarray (T, S, 2) or None
        Weighted samples of the target's position at k+1..k+T (the road tracker's prediction,
        every branch it may have taken), for the sight objective; None: it samples the Gaussians.
    target_sample_weights : ndarray (T, S) or None
        Their weights, each row summing to 1.
    """

    vehicles: VehicleState
    current_turn_rate: NDArray[np.float64]
    max_turn_rate: NDArray[np.float64]
    step_s: float
    target_means: NDArray[np.float64]
    target_covs: NDArray[np.float64]
    sensors: Sequence[SensorModel]
    visibility: Visibility | None
    restricted: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None
    weights: RhcWeights = RhcWeights()
    sight: SightTable | None = None
    guard: AirspaceGuard = AirspaceGuard()
    max_range_m: float = float("inf")
    target_samples: NDArray[np.float64] | None = None
    target_sample_weights: NDArray[np.float64] | None = None

    @cached_property
    def prior_information(self) -> NDArray[np.float64]:
        """``sum_j Y^-[j]`` over the horizon, position block (2, 2): the same for every plan."""
        information: NDArray[np.float64] = np.linalg.inv(self.target_covs[:, :2, :2]).sum(axis=0)
        return information

    @cached_property
    def sensor_groups(self) -> list[tuple[SensorModel, list[int] | None]]:
        """Vehicles grouped by identical sensor (None: every vehicle), one vectorised call each."""
        groups: dict[SensorModel, list[int]] = {}
        for index, sensor in enumerate(self.sensors):
            groups.setdefault(sensor, []).append(index)
        if len(groups) == 1:
            return [(self.sensors[0], None)]
        return list(groups.items())

    @property
    def horizon(self) -> int:
        """T, the number of planned steps."""
        return len(self.target_means)

    @property
    def shape(self) -> tuple[int, int]:
        """(V, T) of one plan."""
        return len(self.vehicles), self.horizon


@dataclass(frozen=True)
class CostBreakdown:
    """Terms of eq. (20)-(29) for a population of P plans."""

    j_in: NDArray[np.float64]  # (P,)
    j_u: NDArray[np.float64]  # (P,)
    j_safe: NDArray[np.float64]  # (P,)
    f_dis: NDArray[np.float64]  # (P,)
    visible: NDArray[np.bool_]  # (P, V, T)
    xy: NDArray[np.float64]  # (P, V, T, 2)

    @property
    def j_rhc(self) -> NDArray[np.float64]:
        """``J_in + J_u + J_safe`` (eq. 20)."""
        return self.j_in + self.j_u + self.j_safe

    @property
    def fitness(self) -> NDArray[np.float64]:
        """``1 / J_rhc + f_dis`` (eq. 28)."""
        return 1.0 / self.j_rhc + self.f_dis


@dataclass(frozen=True)
class PlanResult:
    """Outcome of a planner's solve (Problem -> solve -> Result).

    ``controls`` (V, T) is the best plan; the first column is what the vehicles fly.
    """

    success: bool
    controls: NDArray[np.float64]
    cost: float
    fitness: float
    evaluations: int
    generations: int
    elapsed_s: float
    message: str
    visible_steps: int = 0
    """Vehicle-steps of the best plan from which the predicted target is visible."""


class Planner(Protocol):
    """A planning algorithm: the best team plan for a problem (Problem -> solve -> Result)."""

    def solve(self, problem: PlanningProblem, rng: np.random.Generator,
              warm_start: NDArray[np.float64] | None = None,
              now: Callable[[], float] | None = None) -> PlanResult:
        """``warm_start``: the last plan (V, T), if any; ``now``: a clock for a deadline, if the planner has one."""
        ...


@runtime_checkable
class SharingPlanner(Planner, Protocol):
    """A planner that also shares the vehicles between several targets."""

    def solve_assigned(self, problems: Sequence[PlanningProblem], weights: NDArray[np.float64],
                       rng: np.random.Generator, warm_start: NDArray[np.float64] | None = None,
                       now: Callable[[], float] | None = None) -> PlanResult:
        """One plan for the targets of ``problems`` (one each, beside the same vehicles), weighted ``weights``."""
        ...


def _information(problem: PlanningProblem, xyz: NDArray[np.float64], visible: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``J_in = tr((sum_j [Y^-[j] + sum_i I_i[j]])^-1)`` over the position block, shape (P,)."""
    target_xy = problem.target_means[:, :2]  # (T, 2), broadcasts against (P, V, T)
    seen = visible.astype(np.float64)
    xx = xy = yy = 0.0
    for sensor, members in problem.sensor_groups:
        group = members if members is not None else slice(None)
        i_xx, i_xy, i_yy = sensor.fisher_information_xy(target_xy, xyz[..., group, :, :])
        weight = seen[..., group, :]
        # eq. (22): I_i[j] where the vehicle sees the predicted point ...
        xx = xx + (i_xx * weight).sum(axis=(-1, -2))
        xy = xy + (i_xy * weight).sum(axis=(-1, -2))
        yy = yy + (i_yy * weight).sum(axis=(-1, -2))
    w_vis = problem.weights.w_vis
    if w_vis:  # ... and W_vis I_2 where it does not
        hidden = (1.0 - seen).sum(axis=(-1, -2))
        xx, yy = xx + w_vis * hidden, yy + w_vis * hidden
    prior = problem.prior_information
    a, b, c = xx + prior[0, 0], xy + prior[0, 1], yy + prior[1, 1]
    trace: NDArray[np.float64] = (a + c) / (a * c - b * b)  # trace of the 2 x 2 inverse
    return trace


def evaluate(problem: PlanningProblem, controls: NDArray[np.float64]) -> CostBreakdown:
    """Score plans (P, V, T) with eq. (20)-(29); see the module docstring."""
    w = problem.weights
    u = np.clip(controls, -problem.max_turn_rate[:, None], problem.max_turn_rate[:, None])
    xy, _ = rollout(problem.vehicles, u, problem.step_s, problem.max_turn_rate, headings=False)  # (P, V, T, 2)
    visible = np.ones(xy.shape[:-1], dtype=bool) if problem.visibility is None else problem.visibility.visible(xy)
    altitude = np.broadcast_to(problem.vehicles.altitude[:, None, None], xy.shape[:-1] + (1,))
    xyz = np.concatenate([xy, altitude], axis=-1)
    j_in = _information(problem, xyz, visible)
    change = np.abs(np.diff(u, axis=-1, prepend=np.broadcast_to(problem.current_turn_rate[:, None], u.shape[:-1] + (1,))))
    los_c = np.where(change <= w.u_max_rad_s, change, w.w_u)  # eq. (24)
    j_u = w.control_weight * (np.abs(u) + los_c).sum(axis=(-1, -2))  # eq. (23)
    if problem.restricted is None:
        j_safe = np.zeros(j_in.shape)
    else:
        j_safe = w.w_res * problem.restricted(xyz).sum(axis=(-1, -2))  # eq. (25)-(26)
    blind = ~visible.any(axis=-1)  # (P, V): vehicles that see the target at no step
    if blind.any():
        offset = xy - problem.target_means[:, :2]
        distance = np.hypot(offset[..., 0], offset[..., 1])  # (P, V, T)
        spread = (np.abs(distance - w.standoff_m).sum(axis=-1) * blind).sum(axis=-1)
        f_dis = np.where(blind.any(axis=-1), w.standoff_weight / np.maximum(spread, 1e-9), 0.0)  # eq. (29)
    else:
        f_dis = np.zeros(j_in.shape)
    return CostBreakdown(j_in, j_u, j_safe, f_dis, visible, xy)
