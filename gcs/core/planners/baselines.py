"""Baseline planners on the same Problem -> solve -> Result interface.

* :class:`OrbitPlanner`: each vehicle flies a stand-off circle of radius ``d_r``
  around the current target estimate, vehicles spread evenly in phase; a
  guidance law steers toward the circle's tangent with a radial correction.
* :class:`PursuitPlanner`: each vehicle turns as hard as allowed toward the
  current estimate and flies straight at it.

The paper's own comparison, "k+0" (plan on the current estimate instead of the
k+n prediction), is the GA on a problem whose predicted target points are all
the current estimate; see :func:`gcs.core.tracker.planning_problem`.

Both baselines hold their command over the horizon; only the first is flown.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.planners.problem import PlanningProblem, PlanResult, evaluate

__all__ = ["OrbitPlanner", "PursuitPlanner", "orbit_controls", "orbit_heading", "pursuit_controls"]


def _hold(problem: PlanningProblem, desired_heading: NDArray[np.float64], gain: float) -> NDArray[np.float64]:
    error = wrap_angle(desired_heading - problem.vehicles.heading)
    rate = np.clip(gain * error, -problem.max_turn_rate, problem.max_turn_rate)
    return np.repeat(rate[:, None], problem.horizon, axis=1)


def orbit_controls(problem: PlanningProblem, radius_m: float, gain: float = 1.0) -> NDArray[np.float64]:
    """Turn rates (V, T) toward a counter-clockwise circle of ``radius_m`` about the current estimate.

    The desired heading is the circle's tangent, tilted inward when outside and
    outward when inside by ``atan((d - r) / r)``.
    """
    return _hold(problem, orbit_heading(problem.vehicles.xy, problem.target_means[0, :2], radius_m), gain)


def orbit_heading(xy: NDArray[np.float64], centre: ArrayLike,
                  radius_m: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Heading (V,) that brings vehicles at ``xy`` (V, 2) onto counter-clockwise circles of ``radius_m`` about
    ``centre`` (2 or V, 2): the tangent, tilted by ``atan((d - r) / r)`` toward the circle."""
    offset = xy - np.asarray(centre, dtype=np.float64)
    distance = np.hypot(offset[:, 0], offset[:, 1])
    return np.arctan2(offset[:, 1], offset[:, 0]) + np.pi / 2 + np.arctan((distance - radius_m) / radius_m)


def pursuit_controls(problem: PlanningProblem, gain: float = 1.0) -> NDArray[np.float64]:
    """Turn rates (V, T) toward the current estimate."""
    to_target = problem.target_means[0, :2] - problem.vehicles.xy
    return _hold(problem, np.arctan2(to_target[:, 1], to_target[:, 0]), gain)


def _result(problem: PlanningProblem, controls: NDArray[np.float64], name: str,
            now: Callable[[], float] | None, start: float) -> PlanResult:
    scored = evaluate(problem, controls[None])
    elapsed = now() - start if now is not None else 0.0
    return PlanResult(True, controls, float(scored.j_rhc[0]), float(scored.fitness[0]), 1, 0, elapsed,
                      f"{name} guidance", int(scored.visible[0].sum()))


@dataclass(frozen=True)
class OrbitPlanner:
    """Stand-off orbit of radius ``radius_m`` (default: the problem's ``d_r``), counter-clockwise."""

    radius_m: float | None = None
    gain: float = 1.0

    def solve(self, problem: PlanningProblem, rng: np.random.Generator | None = None,
              warm_start: NDArray[np.float64] | None = None, now: Callable[[], float] | None = None) -> PlanResult:
        start = now() if now is not None else 0.0
        controls = orbit_controls(problem, self.radius_m or problem.weights.standoff_m, self.gain)
        return _result(problem, controls, "orbit", now, start)


@dataclass(frozen=True)
class PursuitPlanner:
    """Straight-line pursuit of the current estimate."""

    gain: float = 1.0

    def solve(self, problem: PlanningProblem, rng: np.random.Generator | None = None,
              warm_start: NDArray[np.float64] | None = None, now: Callable[[], float] | None = None) -> PlanResult:
        start = now() if now is not None else 0.0
        return _result(problem, pursuit_controls(problem, self.gain), "pursuit", now, start)
