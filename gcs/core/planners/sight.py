"""The sight objective: how often at least one UAV will see the target, then how well.

A plan gives every vehicle ``i`` a position ``x_i[j]`` at each horizon step
``j = 1..T`` (eq. 1 rolled out). The target at step ``j`` is uncertain: the
k+j prediction ``N(m_j, P_j)`` (wang2012 eq. 16-17, the spread growing over the
horizon). The objective is written in *seen steps*, the unit a user counts.

**Samples.** ``S`` fixed points ``z_s`` of a standard 2-D normal (a sunflower
pattern, whitened so that their mean is 0 and their covariance exactly I)
give target samples ``t_{j,s} = m_j + L_j z_s`` with ``L_j L_j^T = P_j``
(position block). A ground target cannot be under a roof, so samples that land
on a building get weight 0 and the rest share the step's weight equally
(the prediction conditioned on open ground); if every sample of a step is
under a roof they keep equal weights.

A prediction that comes as weighted samples (the road tracker's,
:class:`gcs.core.roads.RoadHorizon`: particles driven on through the road graph,
branching at junctions) is taken as it is: ``t_{j,s}`` are its samples and
``w_{j,s}`` their weights, those under a roof (the off-road mode's) set to 0 and
the rest normalised as above. The samples then lie down every street the car can
have reached, each branch weighted by its probability, and the manoeuvre spread
below is not added: the branches are the manoeuvres. More than ``B``
(``branch_samples``) samples a step are thinned to ``B`` equally weighted ones by
systematic resampling with the fixed offset 1/2 (sample ``b`` is the first whose
cumulative weight reaches ``(b + 1/2) / B``): the road tracker gives a step's
samples grouped by branch, so every branch keeps its weight to within ``1 / B``;
the cost of the objective stays that of ``B`` samples, and no random number is
drawn.

**Visibility** ``v_{i,j,s}``: vehicle ``i`` at its own altitude ``h_i`` sees sample
``t_{j,s}`` (:class:`gcs.core.world.sight_table.SightTable`, within the sensor's
range).

**Terms**, each per step and summed over ``j``:

* at least one UAV sees the target (the main term, at most 1 per step)

  .. math:: a_j = \\sum_s w_{j,s} \\Big[1 - \\prod_i (1 - v_{i,j,s})\\Big];

* each UAV's own probability of seeing, ``q_{i,j} = \\sum_s w_{j,s} v_{i,j,s}``,
  weighted ``beta / V`` (so all of them together are worth at most ``beta`` a step):
  a second UAV on the target gives a second detection;
* information, bounded: the share of the predicted position variance the
  expected detections remove,

  .. math:: I_j = 1 - \\frac{\\operatorname{tr}\\big((P_j^{-1} + \\sum_i q_{i,j} F_{i,j})^{-1}\\big)}
                             {\\operatorname{tr} P_j} \\in [0, 1),

  weighted ``lambda``, with ``F_{i,j} = H^T (R + \\Omega)^{-1} H`` the Fisher
  information of a detection at the predicted mean, ``Omega`` the
  linearisation's second-order variance
  (:meth:`~gcs.core.models.sensor.SensorModel.linearisation_variance`, which the
  filter adds to ``R`` too): straight above the mean the azimuth tells nothing,
  and the term says so instead of growing as ``1 / rho_h^2`` (eq. 18's limit);
* stand-off shaping, ``(c / V) d_s / (d_s + |d_i - d_r|)`` with ``d_i`` the
  horizontal distance from the vehicle's last planned position to ``m_T``: a
  pull toward the ring where sight is likely that never vanishes, for a UAV
  that sees nothing within the horizon; with ``c < 1`` all of it together is
  worth less than one seen step;
* turn changes, ``-mu sum_j |u_j - u_{j-1}| / eta`` (``u_0`` the command flown now).

**Manoeuvres.** The constant-velocity prediction knows nothing of turns. A
target that may turn at any moment lies, when the prediction has carried it a
distance ``e_j`` from where it is now, within about ``kappa e_j`` of the
straight-line prediction, so the samples are drawn from
``N(m_j, P_j + (kappa e_j)^2 I)`` (``manoeuvre`` = kappa; ``e_j = s t_j`` at
speed ``s``; for the current estimate held over the horizon, the paper's k+0,
``e_j`` stays one step's travel). The information term keeps the filter's ``P_j``.

Constraints: the turn rate is clipped to ``eta`` by the rollout (eq. 1, 27) and
restricted airspace is a hard constraint (:class:`AirspaceGuard`): every
violation costs ``VIOLATION_COST`` seen steps, so an infeasible plan never beats
a feasible one.

The terms of one vehicle given the others' plans are cheap to update
(:class:`TeamView`), which per-vehicle search uses: the value of a whole plan
is the sum of what each vehicle adds, computed for many candidates of one
vehicle at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.kinematics import rollout
from gcs.core.planners.problem import PlanningProblem
from gcs.core.world.sight_table import SightTable

__all__ = ["SightWeights", "VIOLATION_COST", "sample_pattern", "thinned", "SightModel", "Contribution", "contribution", "TeamView",
           "joint_values"]

VIOLATION_COST = 1000.0
"""Seen steps one airspace violation costs: more than any plan can gain."""


@dataclass(frozen=True)
class SightWeights:
    """Weights of the sight objective (module docstring), in seen steps.

    ``per_uav`` (beta), ``information`` (lambda), ``standoff`` (c < 1),
    ``standoff_m`` (d_r) and ``standoff_scale_m`` (d_s), ``turn_change`` (mu),
    ``samples`` (S) of the predicted target distribution per step, and
    ``branch_samples`` (B) of a prediction that comes as samples (the road tracker's).
    """

    per_uav: float = 0.5
    information: float = 0.5
    standoff: float = 0.9
    standoff_m: float = 100.0
    standoff_scale_m: float = 150.0
    turn_change: float = 0.002
    samples: int = 16
    manoeuvre: float = 0.6
    branch_samples: int = 32

    def __post_init__(self) -> None:
        if not 0.0 <= self.standoff < 1.0:
            raise ValueError(f"standoff must be in [0, 1): worth less than one seen step, got {self.standoff!r}")
        if min(self.per_uav, self.information, self.turn_change) < 0.0:
            raise ValueError("per_uav, information and turn_change must be >= 0")
        if not (self.standoff_m >= 0.0 and self.standoff_scale_m > 0.0):
            raise ValueError("standoff_m must be >= 0 and standoff_scale_m > 0")
        if min(self.samples, self.branch_samples) < 1:
            raise ValueError(f"samples and branch_samples must be >= 1, got {self.samples!r}, "
                             f"{self.branch_samples!r}")


def sample_pattern(count: int) -> NDArray[np.float64]:
    """``count`` points (count, 2) of a standard 2-D normal: a sunflower, whitened to mean 0 and covariance I.

    Point ``s`` lies at the radius whose chi-square(2) probability is
    ``(s + 1/2) / count`` (``r = sqrt(-2 ln(1 - u))``), turned by the golden angle
    from the one before. One point is the origin.
    """
    if count == 1:
        return np.zeros((1, 2))
    u = (np.arange(count) + 0.5) / count
    radius = np.sqrt(-2.0 * np.log1p(-u))
    angle = np.arange(count) * (math.pi * (3.0 - math.sqrt(5.0)))
    points = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    points -= points.mean(axis=0)
    cov = points.T @ points / count
    # Whiten: multiply by cov^(-1/2) so that the sample covariance is exactly I.
    values, vectors = np.linalg.eigh(cov)
    whitened: NDArray[np.float64] = points @ (vectors / np.sqrt(values)) @ vectors.T
    return whitened


def thinned(samples: NDArray[np.float64], weights: NDArray[np.float64], count: int
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """At most ``count`` equally weighted samples (T, count, 2) of weighted ones (T, S, 2) with weights (T, S):
    systematic resampling with the fixed offset 1/2 (module docstring); as they are when ``S <= count``."""
    if samples.shape[1] <= count:
        return samples, weights
    cumulative = np.cumsum(weights, axis=1)
    cumulative /= cumulative[:, -1:]
    targets = (np.arange(count) + 0.5) / count
    pick = np.minimum((cumulative[:, :, None] < targets[None, None, :]).sum(axis=1), samples.shape[1] - 1)
    rows = np.take_along_axis(samples, pick[:, :, None], axis=1)
    return rows, np.full(pick.shape, 1.0 / count)


def _gaussian_samples(problem: PlanningProblem, weights: SightWeights) -> NDArray[np.float64]:
    """``t_{j,s} = m_j + L_j z_s`` (T, S, 2) of the k+1..k+T Gaussians, widened by the manoeuvre spread."""
    covs = problem.target_covs[:, :2, :2]
    means = problem.target_means[:, :2]
    now = means[0] - problem.target_means[0, 2:4] * problem.step_s if problem.target_means.shape[1] >= 4 else means[0]
    ahead = np.hypot(*(means - now).T)  # how far the prediction extrapolates
    spread = (weights.manoeuvre * ahead) ** 2
    sampled = 0.5 * (covs + covs.swapaxes(-1, -2)) + spread[:, None, None] * np.eye(2)
    chol = np.linalg.cholesky(sampled)
    offsets: NDArray[np.float64] = np.einsum("tab,sb->tsa", chol, sample_pattern(weights.samples))
    return means[:, None, :] + offsets


@dataclass(frozen=True, eq=False)
class SightModel:
    """One decision step's samples and tables (module docstring); built by :meth:`build`.

    Attributes
    ----------
    samples : ndarray (T, S, 2)
        Target samples ``t_{j,s}``.
    weights : ndarray (T, S)
        Their weights ``w_{j,s}``, each row summing to 1.
    inverse_slopes : ndarray (T * S, bins)
        The sight table of each sample.
    """

    problem: PlanningProblem
    table: SightTable
    weights_cfg: SightWeights
    samples: NDArray[np.float64]
    weights: NDArray[np.float64]
    inverse_slopes: NDArray[np.float32]
    prior_information: NDArray[np.float64]  # (T, 2, 2) P_j^-1
    prior_trace: NDArray[np.float64]  # (T,)

    @classmethod
    def build(cls, problem: PlanningProblem, weights: SightWeights) -> SightModel:
        """Samples, weights and sight tables of ``problem``'s k+1..k+T prediction."""
        table = problem.sight
        if table is None:
            raise ValueError("the sight objective needs the problem's sight table (PlanningProblem.sight)")
        covs = problem.target_covs[:, :2, :2]
        if problem.target_samples is None:
            samples = _gaussian_samples(problem, weights)
            open_ground = table.field.at(samples) <= table.target_height_m
            count = open_ground.sum(axis=1, keepdims=True)
            w = np.where(count > 0, open_ground / np.maximum(count, 1), 1.0 / weights.samples)
        else:
            samples, prior = thinned(np.asarray(problem.target_samples, dtype=np.float64),
                                     np.asarray(problem.target_sample_weights, dtype=np.float64),
                                     weights.branch_samples)
            kept = prior * (table.field.at(samples) <= table.target_height_m)
            total = kept.sum(axis=1, keepdims=True)
            w = np.where(total > 0.0, kept / np.where(total > 0.0, total, 1.0), prior)
        slopes = table.inverse_slopes(samples.reshape(-1, 2))
        return cls(problem, table, weights, samples, w, slopes, np.linalg.inv(covs).astype(np.float64, copy=False),
                   np.trace(covs, axis1=-2, axis2=-1))

    @property
    def horizon(self) -> int:
        return len(self.samples)

    def visible(self, xy: NDArray[np.float64], altitude_m: float) -> NDArray[np.bool_]:
        """``v_{j,s}`` for positions (C, T, 2) of one vehicle at ``altitude_m``: shape (C, T, S)."""
        t, s = self.samples.shape[:2]
        dx = xy[:, :, None, 0] - self.samples[None, :, :, 0]
        dy = xy[:, :, None, 1] - self.samples[None, :, :, 1]
        horizontal2 = dx * dx + dy * dy
        rise = altitude_m - self.table.target_height_m
        reach = self.problem.max_range_m
        seen = (horizontal2 + rise * rise <= reach * reach) & (horizontal2 <= self.table.reach_m ** 2)
        near = np.flatnonzero(seen)  # the roofs are asked about the pairs in range only
        rows = np.broadcast_to(np.arange(t * s).reshape(1, t, s), seen.shape).ravel()[near]
        inverse = self.inverse_slopes[rows, self.table.bin_of(dx.ravel()[near], dy.ravel()[near])]
        seen.ravel()[near] = np.sqrt(horizontal2.ravel()[near]) * inverse <= rise
        return seen


@dataclass(frozen=True, eq=False)
class Contribution:
    """What one vehicle's candidate plans (C of them) bring to the objective."""

    visible: NDArray[np.bool_]  # (C, T, S)
    seen: NDArray[np.float64]  # (C, T): q_{i,j}
    information: NDArray[np.float64]  # (C, T, 3): q_{i,j} F_{i,j} as xx, xy, yy
    own: NDArray[np.float64]  # (C,): per-UAV, stand-off and turn terms, minus violations


def contribution(model: SightModel, vehicle: int, controls: NDArray[np.float64]) -> Contribution:
    """Terms of vehicle ``vehicle`` flying each of ``controls`` (C, T)."""
    problem = model.problem
    cfg = model.weights_cfg
    one = problem.vehicles.subset(vehicle)
    eta = problem.max_turn_rate[vehicle]
    u = np.clip(controls, -eta, eta)
    xy, heading = rollout(one, u[:, None, :], problem.step_s, eta)
    xy, heading = xy[:, 0], heading[:, 0]  # (C, T, 2), (C, T)
    altitude = float(problem.vehicles.altitude[vehicle])
    visible = model.visible(xy, altitude)
    seen = np.einsum("cts,ts->ct", visible, model.weights)
    sensor = problem.sensors[vehicle]
    means = problem.target_means[:, :2]
    xyz = np.concatenate([xy, np.full(xy.shape[:-1] + (1,), altitude)], axis=-1)
    extra = sensor.linearisation_variance(means, xyz, problem.target_covs[:, :2, :2])
    xx, xy_, yy = sensor.fisher_information_xy(means, xyz, extra_variance=extra)
    information = np.stack([xx, xy_, yy], axis=-1) * seen[..., None]
    offset = xy[:, -1] - means[-1]
    distance = np.hypot(offset[..., 0], offset[..., 1])
    shaping = cfg.standoff_scale_m / (cfg.standoff_scale_m + np.abs(distance - cfg.standoff_m))
    team = len(problem.vehicles)
    change = np.abs(np.diff(u, axis=-1, prepend=problem.current_turn_rate[vehicle]))
    violations = problem.guard.violations(xy, heading[:, -1], altitude, float(one.speed[0]), eta)
    own = (cfg.per_uav / team * seen.sum(axis=-1) + cfg.standoff / team * shaping
           - cfg.turn_change * change.sum(axis=-1) / eta - VIOLATION_COST * violations)
    return Contribution(visible, seen, information, own)


class TeamView:
    """The whole team's current plan, kept as each vehicle's :class:`Contribution`, for per-vehicle search.

    :meth:`values` scores candidates of one vehicle with the others' plans held;
    :meth:`accept` replaces that vehicle's plan.
    """

    def __init__(self, model: SightModel, controls: NDArray[np.float64]) -> None:
        self.model = model
        self.controls = np.array(controls, dtype=np.float64)
        self.parts = [_pick(contribution(model, i, self.controls[i:i + 1]), 0) for i in range(len(self.controls))]

    def values(self, vehicle: int, candidates: NDArray[np.float64]) -> tuple[NDArray[np.float64], Contribution]:
        """The objective of the team with ``vehicle`` flying each candidate (C, T): values (C,) and its terms."""
        part = contribution(self.model, vehicle, candidates)
        others = [p for i, p in enumerate(self.parts) if i != vehicle]
        blind = np.ones(self.model.samples.shape[:2])
        information = np.zeros(self.model.samples.shape[:1] + (3,))
        own = 0.0
        for p in others:
            blind = blind * ~p.visible[0]
            information = information + p.information[0]
            own += float(p.own[0])
        return _values(self.model, part, blind[None], information[None]) + own, part

    def accept(self, vehicle: int, candidates: NDArray[np.float64], part: Contribution, index: int) -> None:
        """Make candidate ``index`` of a :meth:`values` call vehicle ``vehicle``'s plan."""
        self.controls[vehicle] = candidates[index]
        self.parts[vehicle] = _pick(part, index)

    def value(self) -> float:
        """The objective of the current team plan."""
        return float(self.values(0, self.controls[:1])[0][0])


def _pick(part: Contribution, index: int) -> Contribution:
    s = slice(index, index + 1)
    return Contribution(part.visible[s], part.seen[s], part.information[s], part.own[s])


def _values(model: SightModel, part: Contribution, others_blind: NDArray[np.float64],
            others_information: NDArray[np.float64]) -> NDArray[np.float64]:
    """Objective (C,) of candidates ``part`` beside the others' blindness (1 or C, T, S) and information
    (1 or C, T, 3)."""
    blind = others_blind * ~part.visible  # (C, T, S): no vehicle sees sample s
    any_seen = 1.0 - np.einsum("cts,ts->ct", blind, model.weights)
    info = others_information + part.information
    a = model.prior_information[None, :, 0, 0] + info[..., 0]
    b = model.prior_information[None, :, 0, 1] + info[..., 1]
    c = model.prior_information[None, :, 1, 1] + info[..., 2]
    posterior_trace = (a + c) / (a * c - b * b)
    gain = 1.0 - posterior_trace / model.prior_trace[None]
    cfg = model.weights_cfg
    objective: NDArray[np.float64] = any_seen.sum(axis=-1) + cfg.information * gain.sum(axis=-1) + part.own
    return objective


def joint_values(model: SightModel, plans: NDArray[np.float64]) -> NDArray[np.float64]:
    """The objective of whole-team plans (K, V, T): (K,), one :func:`contribution` call per vehicle."""
    parts = [contribution(model, i, plans[:, i]) for i in range(plans.shape[1])]
    blind = np.ones((plans.shape[0],) + model.samples.shape[:2])
    information = np.zeros((plans.shape[0], model.horizon, 3))
    own = np.zeros(plans.shape[0])
    for p in parts[1:]:
        blind = blind * ~p.visible
        information = information + p.information
        own = own + p.own
    first = parts[0]
    return _values(model, first, blind, information) + own
