"""Per-vehicle sequential search for the sight objective (anytime, warm-started, never worse than the baselines).

The objective of :mod:`gcs.core.planners.sight` couples the vehicles only
through "at least one sees" and the summed information, and one vehicle's
terms given the others' plans cost one vectorised call for any number of its
candidates. So the search improves one vehicle at a time with the others held
(a best response; the sequential scheme of SMA-NBO, Ragi and Chong's
nominal-belief planners), in few large batches, since in numpy the cost is the
number of calls, not their size:

1. **Start.** The best whole-team plan among the previous plan shifted one step
   (two variants: its appended step turns left or right at full rate, so that
   one keeps its clear loiter circle, :mod:`gcs.core.planners.airspace_guard`),
   the orbit's and the pursuit's plans (already kept out of restricted
   airspace) and straight flight.
2. **Library sweeps.** For each vehicle in turn, the manoeuvre library
   (:func:`gcs.core.planners.primitives.primitives`: 125 plans of three held
   turn rates) plus its rows of every starting plan, scored in one call; the
   best replaces its plan if it is better. ``sweeps`` rounds.
3. **Refinement.** ``refine_sweeps`` rounds of the same with Gaussian
   perturbations of each vehicle's plan (``refine_scale * eta`` per step).

Every round keeps the current plan among the candidates, so the value never
decreases: the result is never worse, on this objective, than the shifted plan
or any baseline. With a clock (``now``) the search stops at ``deadline_s``
after the vehicle it is on and returns the best plan so far.

**Order under a deadline.** The rounds visit the vehicles one after another,
``V (sweeps + refine_sweeps)`` visits in all. A deadline ends the search part way
through a round, and with a fixed order the vehicle that loses its visit would
always be the last one: the same vehicle, solve after solve, flies the least
improved plan. With a clock the first vehicle is therefore drawn from ``rng`` for
each solve and the visits go round cyclically from it, so every vehicle is the one
cut short equally often. Without a clock every visit is made, in the order
``0 .. V-1`` each round.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.planners.airspace_guard import shift_into_circle
from gcs.core.planners.baselines import orbit_controls, pursuit_controls
from gcs.core.planners.primitives import LEVELS, primitives
from gcs.core.planners.problem import PlanningProblem, PlanResult
from gcs.core.planners.shared import SharedView, assign_vehicles, shared_joint_values, vehicles_subproblem
from gcs.core.planners.sight import SightModel, SightWeights

__all__ = ["SightPlanner"]


@dataclass(frozen=True)
class SightPlanner:
    """Parameters of the per-vehicle search (module docstring) and of the objective it maximises."""

    weights: SightWeights = field(default_factory=SightWeights)
    sweeps: int = 2
    refine_sweeps: int = 1
    refine_candidates: int = 24
    refine_scale: float = 0.3
    levels: tuple[float, ...] = LEVELS
    segments: int = 3
    deadline_s: float | None = 0.5
    orbit_radius_m: float | None = None
    """Radius of the orbit baseline among the starting plans (None: the problem's stand-off ``d_r``)."""

    def __post_init__(self) -> None:
        if self.sweeps < 1 or self.refine_sweeps < 0 or self.refine_candidates < 1:
            raise ValueError("sweeps must be >= 1, refine_sweeps >= 0 and refine_candidates >= 1")

    def starts(self, problem: PlanningProblem, warm_start: NDArray[np.float64] | None,
               others: Sequence[PlanningProblem] = ()) -> NDArray[np.float64]:
        """The whole-team plans the search starts from (K, V, T), guarded against restricted airspace: straight
        flight, the orbit and the pursuit of ``problem``'s target and of each of ``others``' targets, and the
        warm start shifted."""
        vehicles, steps = problem.shape
        eta = problem.max_turn_rate
        plans = [np.zeros((vehicles, steps))]
        for target in (problem, *others):
            plans += [orbit_controls(target, self.orbit_radius_m or target.weights.standoff_m),
                      pursuit_controls(target)]
        if warm_start is not None and warm_start.shape == (vehicles, steps):
            plans.extend(shift_into_circle(warm_start, eta))
        return problem.guard.safe(problem.vehicles, np.stack(plans), problem.step_s, eta)

    def solve(self, problem: PlanningProblem, rng: np.random.Generator,
              warm_start: NDArray[np.float64] | None = None,
              now: Callable[[], float] | None = None) -> PlanResult:
        """The best team plan found (see the module docstring)."""
        return self.solve_shared([problem], np.ones(1), rng, warm_start, now)

    def solve_shared(self, problems: Sequence[PlanningProblem], weights: NDArray[np.float64],
                     rng: np.random.Generator, warm_start: NDArray[np.float64] | None = None,
                     now: Callable[[], float] | None = None) -> PlanResult:
        """The best team plan for the weighted sum over targets (:mod:`gcs.core.planners.shared`), one problem
        per target; with one problem and weight 1, :meth:`solve`."""
        start_s = now() if now is not None else 0.0

        def late() -> bool:
            return now is not None and self.deadline_s is not None and now() - start_s >= self.deadline_s

        problem = problems[0]
        models = [SightModel.build(p, self.weights) for p in problems]
        starts = self.starts(problem, warm_start, problems[1:])
        values = shared_joint_values(models, weights, starts)
        team = SharedView(models, weights, starts[int(np.argmax(values))])
        evaluations, message = len(starts), "ran every round"
        vehicles, steps = problem.shape
        visits = vehicles * (self.sweeps + self.refine_sweeps)
        first = int(rng.integers(vehicles)) if now is not None else 0
        best = float(values.max())
        done = 0
        for done in range(visits):
            if late():
                message = f"deadline {self.deadline_s:g} s reached after {done} of {visits} vehicle visits"
                break
            round_index, i = done // vehicles, (first + done) % vehicles
            eta = float(problem.max_turn_rate[i])
            current = team.controls[i:i + 1]
            if round_index < self.sweeps:
                extra = [primitives(eta, steps, self.levels, self.segments), starts[:, i]]
            else:
                noise = rng.normal(0.0, self.refine_scale * eta, (self.refine_candidates, steps))
                extra = [np.clip(current + noise, -eta, eta)]
            candidates = np.concatenate([current, *extra])
            scores, part = team.values(i, candidates)
            evaluations += len(candidates)
            pick = int(np.argmax(scores))
            if scores[pick] > scores[0]:
                team.accept(i, candidates, part, pick)
                best = float(scores[pick])
        else:
            done = visits
        rounds = done // vehicles
        elapsed = now() - start_s if now is not None else 0.0
        return PlanResult(success=bool(np.isfinite(best)), controls=team.controls.copy(), cost=-best, fitness=best,
                          evaluations=evaluations, generations=rounds, elapsed_s=elapsed, message=message,
                          visible_steps=int(round(team.seen_steps())))

    def solve_assigned(self, problems: Sequence[PlanningProblem], weights: NDArray[np.float64],
                       rng: np.random.Generator, warm_start: NDArray[np.float64] | None = None,
                       now: Callable[[], float] | None = None) -> PlanResult:
        """Each vehicle assigned one target (:func:`~gcs.core.planners.shared.assign_vehicles`), then each
        target planned for with its own vehicles alone, the deadline split between the targets."""
        start_s = now() if now is not None else 0.0
        problem = problems[0]
        assigned = assign_vehicles(problem.vehicles, np.array([p.target_means[0, :2] for p in problems]), weights)
        groups = [(k, np.flatnonzero(assigned == k)) for k in range(len(problems)) if np.any(assigned == k)]
        per_group = replace(self, deadline_s=None if self.deadline_s is None else self.deadline_s / len(groups))
        controls = np.zeros(problem.shape)
        fitness, evaluations, seen = 0.0, 0, 0
        for k, idx in groups:
            warm = None if warm_start is None or warm_start.shape != problem.shape else warm_start[idx]
            result = per_group.solve(vehicles_subproblem(problems[k], idx), rng, warm, now)
            controls[idx] = result.controls
            fitness += float(weights[k]) * result.fitness
            evaluations += result.evaluations
            seen += result.visible_steps
        elapsed = now() - start_s if now is not None else 0.0
        return PlanResult(success=bool(np.isfinite(fitness)), controls=controls, cost=-fitness, fitness=fitness,
                          evaluations=evaluations, generations=0, elapsed_s=elapsed,
                          message=f"assigned {assigned.tolist()}", visible_steps=seen)
