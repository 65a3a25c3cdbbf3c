"""zuo2021's one-step heading planners behind the receding-horizon interface the tracker calls.

:func:`gcs.core.tracker.plan` hands every planner a :class:`PlanningProblem`
(wang2012's: vehicles, predicted target states k+1..k+T with covariances,
sensors) and expects a :class:`PlanResult` of turn rates (V, T). zuo2021's
planners decide one step: the headings at k+1 that minimise the bound at the
predicted k+1 target (eq. 34-39). :class:`OneStepHeadingPlanner` builds their
:class:`HeadingProblem` from the first predicted state, solves it, and returns
the chosen turn rate held over the horizon (the plan is re-made every step).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from gcs.core.planners.lm_gcrlb import HeadingProblem, HeadingResult
from gcs.core.planners.problem import PlanningProblem, PlanResult

__all__ = ["HeadingSolver", "OneStepHeadingPlanner"]


class HeadingSolver(Protocol):
    """A one-step heading planner of zuo2021 (eq. 34-39): the headings for the next step."""

    def solve(self, problem: HeadingProblem, now: Callable[[], float] | None = None) -> HeadingResult: ...


@dataclass(frozen=True)
class OneStepHeadingPlanner:
    """Adapter: a zuo2021 heading planner (:class:`~gcs.core.planners.lm_gcrlb.LmGcrlbPlanner`,
    ``crlb_planner()``, :class:`~gcs.core.planners.lm_gcrlb.StraightLinePlanner`) as a tracker planner.

    ``max_detection_range_m``, ``min_separation_m`` and ``max_separation_m`` are the
    constraints of eq. (37)-(39).
    """

    solver: HeadingSolver
    max_detection_range_m: float = 20_000.0
    min_separation_m: float = 200.0
    max_separation_m: float = 7_500.0

    def heading_problem(self, problem: PlanningProblem) -> HeadingProblem:
        """eq. (34)-(39) at the first predicted target state (k+1)."""
        vehicles = problem.vehicles
        return HeadingProblem(
            vehicle_xyz=vehicles.xyz, heading=vehicles.heading, speed_mps=vehicles.speed, step_s=problem.step_s,
            max_turn_rad=problem.max_turn_rate * problem.step_s, target_xy=problem.target_means[0, :2],
            prior_information=np.linalg.inv(problem.target_covs[0, :2, :2]).astype(np.float64, copy=False),
            sensors=tuple(problem.sensors),
            max_detection_range_m=self.max_detection_range_m, min_separation_m=self.min_separation_m,
            max_separation_m=self.max_separation_m)

    def solve(self, problem: PlanningProblem, rng: np.random.Generator,
              warm_start: NDArray[np.float64] | None = None,
              now: Callable[[], float] | None = None) -> PlanResult:
        """The one-step decision, its turn rate held over the horizon (V, T)."""
        result = self.solver.solve(self.heading_problem(problem), now=now)
        controls = np.repeat(result.turn_rate_rad_s[:, None], problem.horizon, axis=1)
        return PlanResult(success=result.success, controls=controls, cost=result.objective,
                          fitness=-result.objective, evaluations=result.evaluations, generations=result.iterations,
                          elapsed_s=result.elapsed_s, message=result.message)
