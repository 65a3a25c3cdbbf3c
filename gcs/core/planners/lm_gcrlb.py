"""One-step heading planner of zuo2021 section 4: minimise tr(GCRLB) by penalty + Levenberg-Marquardt.

At decision step k every vehicle i picks the heading ``phi_i(k)`` it flies for the
next step ``T`` at its speed ``v_i`` (eq. 35):

.. math::
    S_i(k+1) = S_i(k) + v_i T \\, (\\cos \\varphi_i(k), \\sin \\varphi_i(k))

and the team minimises the trace of the bound on the target position at k+1
(eq. 34), the information of the predicted target ``x_{k+1|k}`` seen from the new
positions, eq. (15)-(17) (:func:`gcs.core.gcrlb.fisher_information`), plus the
predicted information ``Y^- = (P_{k+1|k})^{-1}`` of the position block:

.. math::
    f(\\varphi) = \\operatorname{tr}\\big[(Y^- + J(x_{k+1|k}, S(k+1)))^{-1}\\big]  \\qquad (34)

subject to the turn limit ``|phi_i(k) - phi_i(k-1)| <= phi_max`` (eq. 36), the
detection range ``||S_tar - S_i(k+1)|| <= r_dmax`` (eq. 37) and the inter-vehicle
band ``r_smin <= ||S_i(k+1) - S_j(k+1)|| <= r_smax`` (eq. 38-39; the paper's
eq. (43)-(44) measure the target-vehicle distance and swap the two names, a
misprint: the band is between vehicles, 200 m to 7500 m in its section 5).

How each constraint is handled:

* **Turn limit, exactly.** The unknowns are ``s_i`` in R with
  ``phi_i(k) = phi_i(k-1) + phi_max,i sin(s_i)``: every ``s`` is an allowed heading
  and every allowed heading is reached (``s`` in [-pi/2, pi/2] is a bijection), so
  eq. (36) holds for any iterate and the penalty ``g_1`` of eq. (41) is always 0.
  ``sin`` rather than ``tanh``: the bounds are reached at finite ``s`` (where the
  cost is locally quadratic in ``s``), which the optimum often is.
* **Detection range and distance band, by penalty** (eq. 40, 42-44): the squared
  hinges ``mu max(0, excess)^2`` of each vehicle's range beyond ``r_dmax`` and each
  pair's distance below ``r_smin`` or above ``r_smax``, in metres. Squared (the paper
  writes the plain hinge) so that the residuals below are differentiable. An
  exterior penalty leaves an overshoot of order ``1 / mu``; the hinges start
  ``margin_m`` inside each bound so that the overshoot stays inside the true one.
* **Lookahead (ours).** Eq. (37)-(39) at k+1 alone are myopic: two vehicles that
  reach 7500 m flying apart cannot stop separating within one step, and the
  paper's one-step planner would break the band on the following steps. So each
  distance is penalised where it would end if, from k+1 on, the vehicles turned
  at their limit to stop closing on the bound: a vehicle whose velocity has the
  fraction ``c`` toward the bound drifts ``R (1 - sqrt(1 - c^2)) <= R c^2`` further
  while turning (``R = v T / phi_max``, 573 m here), and the penalty uses the smooth
  upper bound ``R max(c, 0)^2``, per vehicle (``lookahead=False`` gives eq. 37-39 as
  printed). A constraint that still cannot be met is violated as little as the
  turn limit allows; the result counts the violations at k+1 against the true bounds.

**Levenberg-Marquardt** needs a sum of squares. With ``Y = Y^- + J = L L^T``
(Cholesky, 2 x 2), ``tr(Y^-1) = ||L^-1||_F^2``, so the three entries of ``L^-1``
(divided by ``sqrt(f_0)``, ``f_0`` the trace for unchanged headings, so that the
objective is about 1) and the ``sqrt(mu)``-weighted hinges are residuals whose
squared sum is exactly the penalised cost of eq. (40). The LM loop is Madsen,
Nielsen & Tingleff's (2004, algorithm 3.16: damping ``lambda I``, gain-ratio
update); its Jacobian is the central difference of the residuals, all ``2 M + 1``
stencil points scored in one vectorised call of the Fisher information. It starts
from the best of the current headings and a few turns (see :meth:`LmGcrlbPlanner.solve`)
and finds a local minimum. Because the residuals do not vanish at the optimum,
``J^T J`` misses the curvature of the cost: the initial damping caps the first
step, and where an optimum lies inside the turn range (rather than at its limit,
which is usual over one 4 deg step) convergence is linear (tens of iterations).

Planners, all ``solve(problem, now=None) -> HeadingResult``:

* :class:`LmGcrlbPlanner`: the above (zuo2021, "GCRLB-LM").
* :func:`crlb_planner`: the same optimisation with constant-noise information
  (every sensor's ``sigma_0`` at any range, so ``J_2 = 0``): Dogancay's (2012)
  CRLB-trace planner, the paper's ref. [7].
* :class:`StraightLinePlanner`: turn toward the predicted target as fast as
  eq. (36) allows (the paper's "straight-line" comparison).

The core has no clock: ``now`` (seconds) times the solve when given.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.models.sensor import SensorModel
from gcs.core.planners.heading_problem import (HeadingProblem, HeadingResult, Violations, constraint_excess, information,
                                               next_positions, trace_bound, violations)

__all__ = [
    "HeadingProblem", "HeadingResult", "Violations", "LmGcrlbPlanner", "StraightLinePlanner", "crlb_planner",
    "next_positions", "trace_bound", "violations",
]


def _normaliser(problem: HeadingProblem, sensors: Sequence[SensorModel]) -> float | None:
    """``f_0``, the bound's trace for the headings kept, which normalises the cost; None where it is not a
    positive number (no information, or a degenerate geometry such as a vehicle right above the target)."""
    scale = float(trace_bound(problem, np.zeros(len(sensors)), sensors))
    return scale if np.isfinite(scale) and scale > 0.0 else None


@lru_cache(maxsize=64)
def _constant_noise(sensor: SensorModel) -> SensorModel:
    return dataclasses.replace(sensor, distance_dependent=False)


def _result(problem: HeadingProblem, change: NDArray[np.float64], cost: float, evaluations: int, iterations: int,
            success: bool, message: str, now: Callable[[], float] | None, start: float) -> HeadingResult:
    change = np.asarray(change, dtype=np.float64)
    bound = trace_bound(problem, np.stack([change, np.zeros_like(change)]))
    violated = violations(problem, change)
    if violated.total:
        success, message = False, f"{message}; violates {violated}"
    elapsed = now() - start if now is not None else 0.0
    return HeadingResult(success, wrap_angle(problem.heading + change), change, change / problem.step_s,
                         float(bound[0]), float(bound[1]), cost, violated, evaluations, iterations, elapsed, message)


@dataclass(frozen=True)
class LmGcrlbPlanner:
    """Penalty + Levenberg-Marquardt parameters (module docstring).

    Attributes
    ----------
    constant_noise : bool
        Minimise the constant-noise CRLB instead (Dogancay's planner; :func:`crlb_planner`).
    penalty : float
        ``mu`` of eq. (40), per square metre, against the objective normalised to 1.
    margin_m : float
        How far inside each bound the penalties start.
    lookahead : bool
        Penalise the distances the vehicles would reach after turning at their limit
        from k+1 on (module docstring), not only those at k+1 (eq. 37-39 as printed).
    max_iterations : int
    gtol, xtol, ftol : float
        Stop when the gradient's largest entry, the step (relative to ``s``) or the
        relative decrease of the cost falls below these.
    damping : float
        ``tau`` of the initial damping ``tau max diag(J^T J)``.
    difference_step : float
        Central-difference step in ``s``.
    initial_step : float
        Largest first step in ``s`` (sets the initial damping; see :meth:`solve`).
    """

    constant_noise: bool = False
    penalty: float = 1e4
    margin_m: float = 1.0
    lookahead: bool = True
    max_iterations: int = 100
    gtol: float = 1e-9
    xtol: float = 1e-8
    ftol: float = 1e-9
    damping: float = 1e-3
    difference_step: float = 1e-6
    initial_step: float = 1.0

    @property
    def name(self) -> str:
        """The paper's name for the planner."""
        return "CRLB-LM (Dogancay)" if self.constant_noise else "GCRLB-LM"

    def _residuals(self, problem: HeadingProblem, sensors: Sequence[SensorModel], s: NDArray[np.float64],
                   scale: float) -> NDArray[np.float64]:
        """Residuals (..., 3 + M + 2 P) of eq. (40) for parameters s (..., M): entries of ``L^-1 / sqrt(f_0)``
        and the weighted hinges (module docstring); their squared sum is the penalised cost."""
        change = problem.max_turn_rad * np.sin(s)
        xyz = next_positions(problem, change)
        info = information(problem, sensors, xyz)
        l11 = np.sqrt(info[..., 0, 0])
        l21 = info[..., 0, 1] / l11
        l22 = np.sqrt(info[..., 1, 1] - l21 * l21)
        chol_inv = np.stack([1.0 / l11, -l21 / (l11 * l22), 1.0 / l22], axis=-1) / math.sqrt(scale)
        excess = constraint_excess(problem, xyz, self.margin_m, problem.heading + change if self.lookahead else None)
        return np.concatenate([chol_inv, math.sqrt(self.penalty) * excess], axis=-1)

    def _costs(self, problem: HeadingProblem, sensors: Sequence[SensorModel], s: NDArray[np.float64],
               scale: float) -> NDArray[np.float64]:
        """Penalised costs (...,) for parameters s (..., M); NaN where the geometry is degenerate."""
        res = self._residuals(problem, sensors, s, scale)
        costs: NDArray[np.float64] = np.einsum("...k,...k->...", res, res)
        return costs

    def _sensors(self, problem: HeadingProblem) -> tuple[SensorModel, ...]:
        """The sensors of the planner's information model."""
        return tuple(_constant_noise(s) for s in problem.sensors) if self.constant_noise else tuple(problem.sensors)

    def cost(self, problem: HeadingProblem, heading_change: NDArray[np.float64]) -> NDArray[np.float64]:
        """The penalised, normalised cost of eq. (40) that :meth:`solve` minimises, for changes (..., M)."""
        sensors = self._sensors(problem)
        scale = _normaliser(problem, sensors)
        if scale is None:  # no information at the kept headings: the cost solve() reports then
            return np.full(np.shape(heading_change)[:-1], math.inf)
        ratio = np.divide(heading_change, problem.max_turn_rad, out=np.zeros(np.shape(heading_change)),
                          where=problem.max_turn_rad > 0)
        return self._costs(problem, sensors, np.arcsin(np.clip(ratio, -1.0, 1.0)), scale)

    def solve(self, problem: HeadingProblem, now: Callable[[], float] | None = None) -> HeadingResult:
        """LM from the best start (see the code); returns the last iterate, which is the best."""
        start = now() if now is not None else 0.0
        sensors = self._sensors(problem)
        m = len(sensors)
        scale = _normaliser(problem, sensors)
        if scale is None:
            return _result(problem, np.zeros(m), math.inf, 1, 0, False, "no information: headings kept", now, start)
        h = self.difference_step
        stencil = np.concatenate([np.zeros((1, m)), h * np.eye(m), -h * np.eye(m)])  # (2M + 1, M)

        def evaluate(s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            """Residuals (R,) at s and their central-difference Jacobian (R, M), one vectorised call."""
            res = self._residuals(problem, sensors, s + stencil, scale)
            return res[0], ((res[1:m + 1] - res[m + 1:]) / (2.0 * h)).T

        # The start: the best of s = 0 (headings kept) and s = +-pi/4 (+-0.71 phi_max) for each vehicle alone
        # and for all together, scored in one call. Turning off s = 0 breaks symmetric stationary points
        # (e.g. flying straight away from a bound, where every gradient is zero).
        starts = np.concatenate([np.zeros((1, m)), np.eye(m), -np.eye(m), np.ones((1, m)), -np.ones((1, m))])
        starts *= 0.25 * np.pi
        start_costs = self._costs(problem, sensors, starts, scale)
        s = starts[int(np.argmin(np.where(np.isfinite(start_costs), start_costs, np.inf)))]
        r, jac = evaluate(s)
        evaluations, iterations = len(starts) + len(stencil), 0
        cost = float(r @ r)
        a, g = jac.T @ jac, jac.T @ r
        # Initial damping: tau max diag(J^T J) (Madsen et al.), but at least |g| / initial_step, so that the
        # first step is at most ``initial_step`` in s: the residuals are far from zero (f > 0 at the optimum)
        # and the undamped Gauss-Newton step, which aims at f = 0, would be thousands of radians.
        lam = max(self.damping * float(np.max(np.diag(a), initial=0.0)), float(np.linalg.norm(g)) / self.initial_step)
        nu = 2.0
        message = f"reached {self.max_iterations} iterations"
        converged = False
        while iterations < self.max_iterations:
            if np.max(np.abs(g)) <= self.gtol:
                message, converged = "gradient below gtol", True
                break
            iterations += 1
            step = np.linalg.solve(a + lam * np.eye(m), -g)
            if not np.all(np.isfinite(step)):
                message = "non-finite step (degenerate geometry); stopped"
                break
            if np.linalg.norm(step) <= self.xtol * (np.linalg.norm(s) + self.xtol):
                message, converged = "step below xtol", True
                break
            r_new, jac_new = evaluate(s + step)
            evaluations += len(stencil)
            cost_new = float(r_new @ r_new)
            predicted = float(step @ (lam * step - g))  # twice the model's decrease (Madsen et al. eq. 3.14)
            gain = (cost - cost_new) / predicted if predicted > 0.0 else -1.0
            if gain > 0.0 and np.isfinite(cost_new):
                decrease = cost - cost_new
                s, r, jac, cost = s + step, r_new, jac_new, cost_new
                a, g = jac.T @ jac, jac.T @ r
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
                nu = 2.0
                if decrease <= self.ftol * cost:
                    message, converged = "relative decrease below ftol", True
                    break
            else:
                lam *= nu
                nu *= 2.0
        change = problem.max_turn_rad * np.sin(s)
        return _result(problem, change, cost, evaluations, iterations, converged, message, now, start)


def crlb_planner(**parameters: float | int) -> LmGcrlbPlanner:
    """Dogancay's CRLB-trace planner: :class:`LmGcrlbPlanner` on constant-noise information."""
    return LmGcrlbPlanner(constant_noise=True, **parameters)  # type: ignore[arg-type]


@dataclass(frozen=True)
class StraightLinePlanner:
    """Turn toward the predicted target as fast as eq. (36) allows, then fly straight at it."""

    name: str = "straight line"

    def solve(self, problem: HeadingProblem, now: Callable[[], float] | None = None) -> HeadingResult:
        """Heading change ``clip(wrap(bearing - phi(k-1)), +-phi_max)``."""
        start = now() if now is not None else 0.0
        offset = problem.target_xy - problem.vehicle_xyz[:, :2]
        desired = np.arctan2(offset[:, 1], offset[:, 0])
        change = np.clip(wrap_angle(desired - problem.heading), -problem.max_turn_rad, problem.max_turn_rad)
        objective = float(trace_bound(problem, change))
        return _result(problem, change, objective, 1, 0, True, "toward the predicted target", now, start)
