"""Whole-team searches of the sight objective, the alternatives to per-vehicle search: cross-entropy and a GA.

The cross-entropy method (Rubinstein 1999; in planning, the MPPI / CEM family)
samples ``batch`` team plans (V, T) from an independent Gaussian per turn-rate
command, scores them in one call (:func:`gcs.core.planners.sight.joint_values`),
refits the Gaussian to the best ``elite`` of them, and repeats ``iterations``
times. Its mean starts at the best of the same starting plans as
:class:`~gcs.core.planners.sequential.SightPlanner` (the shifted previous
plan, the baselines, straight flight), which stay in every batch, so it too is
never worse than them on the objective.

:class:`SightGeneticPlanner` is wang2012's GA with its operators unchanged,
scoring the sight objective. ``gcs-bench urban --planners sight sight_cem
sight_ga`` compares the three searches in the closed loop on paired seeds
(docs/benchmarks.md gives the measurement that made the per-vehicle search the
default).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.planners.ga import GeneticPlanner
from gcs.core.planners.problem import PlanningProblem, PlanResult
from gcs.core.planners.sequential import SightPlanner
from gcs.core.planners.sight import SightModel, SightWeights, joint_values

__all__ = ["CrossEntropyPlanner", "SightGeneticPlanner"]


@dataclass(frozen=True)
class CrossEntropyPlanner:
    """Parameters of the cross-entropy search (module docstring)."""

    weights: SightWeights = field(default_factory=SightWeights)
    batch: int = 64
    elite: int = 8
    iterations: int = 5
    initial_scale: float = 0.5
    """Standard deviation of the first batch, as a fraction of each vehicle's maximum turn rate."""
    deadline_s: float | None = 0.5

    def __post_init__(self) -> None:
        if not 1 <= self.elite < self.batch or self.iterations < 1:
            raise ValueError("need 1 <= elite < batch and iterations >= 1")

    def solve(self, problem: PlanningProblem, rng: np.random.Generator,
              warm_start: NDArray[np.float64] | None = None,
              now: Callable[[], float] | None = None) -> PlanResult:
        """The best team plan of every batch (see the module docstring)."""
        start_s = now() if now is not None else 0.0
        model = SightModel.build(problem, self.weights)
        starts = SightPlanner(self.weights).starts(problem, warm_start)
        values = joint_values(model, starts)
        best = int(np.argmax(values))
        best_plan, best_value = starts[best].copy(), float(values[best])
        eta = problem.max_turn_rate[:, None]
        mean, std = best_plan.copy(), np.broadcast_to(self.initial_scale * eta, best_plan.shape).copy()
        evaluations, done, message = len(starts), 0, f"ran all {self.iterations} iterations"
        for _ in range(self.iterations):
            if now is not None and self.deadline_s is not None and now() - start_s >= self.deadline_s:
                message = f"deadline {self.deadline_s:g} s reached after {done} iterations"
                break
            drawn = np.clip(mean + std * rng.standard_normal((self.batch - len(starts) - 1,) + mean.shape), -eta, eta)
            batch = np.concatenate([best_plan[None], starts, drawn])
            scores = joint_values(model, batch)
            evaluations += len(batch)
            order = np.argsort(scores)[::-1][: self.elite]
            if scores[order[0]] > best_value:
                best_value, best_plan = float(scores[order[0]]), batch[order[0]].copy()
            elite = batch[order]
            mean, std = elite.mean(axis=0), np.maximum(elite.std(axis=0), 0.02 * eta)
            done += 1
        elapsed = now() - start_s if now is not None else 0.0
        return PlanResult(success=bool(np.isfinite(best_value)), controls=best_plan, cost=-best_value,
                          fitness=best_value, evaluations=evaluations, generations=done, elapsed_s=elapsed,
                          message=message)


@dataclass(frozen=True)
class SightGeneticPlanner(GeneticPlanner):
    """wang2012's GA operators (:mod:`gcs.core.planners.ga`) searching the sight objective instead of eq. (28)."""

    weights: SightWeights = field(default_factory=SightWeights)

    def scorer(self, problem: PlanningProblem) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
        model = SightModel.build(problem, self.weights)
        return lambda population: joint_values(model, population)

    def final_terms(self, problem: PlanningProblem, plan: NDArray[np.float64]) -> tuple[float, int]:
        return -float(self.scorer(problem)(plan[None])[0]), 0
