"""Genetic algorithm for the RHC problem (wang2012 section 4.2), anytime and warm-started.

Encoding (eq. 27): a chromosome is the ``V x T`` matrix of turn rates, each in
``[-eta_max_i, eta_max_i]``. Fitness is eq. (28)-(29) from
:func:`gcs.core.planners.problem.evaluate`, computed for the whole population at
once. The paper leaves the operators open ("not repeated here"); ours:

* initial population: the previous best plan shifted by one step (its last
  command repeated), mutated copies of it, constant-turn plans (each vehicle
  hard left, straight or hard right, the fan of manoeuvres a fixed-wing can
  fly) and uniform random plans;
* selection: binary tournament;
* crossover (probability ``crossover_rate``): uniform by vehicle, each child
  row taken whole from one parent, so a vehicle's manoeuvre stays coherent,
  followed by an arithmetic blend of the two parents' rows with a random weight;
* mutation: each gene with probability ``mutation_rate`` gets Gaussian noise of
  ``mutation_scale * eta_max``, clipped to the bounds;
* elitism: the ``elite`` best plans survive unchanged, so the best fitness
  never decreases;
* stop: after ``generations`` generations, or at the deadline when a clock is
  given (anytime: the best plan so far is returned), or after ``stall``
  generations without improvement when set.

The clock is an argument (``now``), never read here: the core has no clock.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.planners.problem import PlanningProblem, PlanResult, evaluate

__all__ = ["GeneticPlanner", "shift_plan"]


def shift_plan(controls: NDArray[np.float64]) -> NDArray[np.float64]:
    """The previous plan moved one step on: drop the flown command, repeat the last (V, T)."""
    return np.concatenate([controls[:, 1:], controls[:, -1:]], axis=1)


@dataclass(frozen=True)
class GeneticPlanner:
    """GA parameters (the paper: 50 chromosomes, at most 200 generations, under 1 s)."""

    population: int = 50
    generations: int = 200
    deadline_s: float | None = 1.0
    elite: int = 2
    crossover_rate: float = 0.9
    mutation_rate: float = 0.15
    mutation_scale: float = 0.3
    stall: int | None = None

    def __post_init__(self) -> None:
        if self.population < 4 or not 0 <= self.elite < self.population:
            raise ValueError("population must be >= 4 and elite in [0, population)")

    def initial_population(
        self, problem: PlanningProblem, rng: np.random.Generator, warm_start: NDArray[np.float64] | None
    ) -> NDArray[np.float64]:
        """Seeds described in the module docstring, shape (population, V, T)."""
        vehicles, steps = problem.shape
        eta = problem.max_turn_rate[:, None]
        seeds = []
        if warm_start is not None:
            shifted = np.clip(shift_plan(warm_start), -eta, eta)
            seeds.append(shifted)
            for _ in range(self.population // 5):
                seeds.append(np.clip(shifted + rng.normal(0.0, 0.3, shifted.shape) * eta, -eta, eta))
        for choice in (-1.0, 0.0, 1.0):
            seeds.append(np.broadcast_to(choice * eta, (vehicles, steps)).copy())
        count = self.population - len(seeds)
        if count > 0:
            fan = rng.choice([-1.0, 0.0, 1.0], size=(count // 2, vehicles, 1)) * eta
            seeds.extend(np.broadcast_to(fan, (count // 2, vehicles, steps)))
            seeds.extend(rng.uniform(-1.0, 1.0, size=(count - count // 2, vehicles, steps)) * eta)
        return np.stack(seeds[: self.population])

    def _offspring(self, parents_a: NDArray[np.float64], parents_b: NDArray[np.float64],
                   eta: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float64]:
        n, vehicles, _ = parents_a.shape
        draws = rng.random((n, vehicles, 4))  # per child and vehicle: row choice, blend weight, operator, crossover
        rows = np.where(draws[..., :1] < 0.5, parents_a, parents_b)
        blend = draws[..., 1:2]
        mixed = parents_b + blend * (parents_a - parents_b)
        crossed = np.where(draws[:, :1, 2:3] < 0.5, rows, mixed)
        children = np.where(draws[:, :1, 3:4] < self.crossover_rate, crossed, parents_a)
        noise = rng.normal(0.0, self.mutation_scale, children.shape)
        noise *= rng.random(children.shape) < self.mutation_rate
        clipped: NDArray[np.float64] = np.clip(children + noise * eta, -eta, eta)
        return clipped

    def solve(
        self,
        problem: PlanningProblem,
        rng: np.random.Generator,
        warm_start: NDArray[np.float64] | None = None,
        now: Callable[[], float] | None = None,
    ) -> PlanResult:
        """Best plan found within the generation budget (and the deadline, if ``now`` is given)."""
        start = now() if now is not None else 0.0
        eta = problem.max_turn_rate[:, None]
        score = self.scorer(problem)
        population = self.initial_population(problem, rng, warm_start)
        fitness = score(population)
        evaluations = len(population)
        best = int(np.argmax(fitness))
        best_fitness, best_plan = float(fitness[best]), population[best].copy()
        generations, stalled, message = 0, 0, f"ran all {self.generations} generations"
        while generations < self.generations:
            if now is not None and self.deadline_s is not None and now() - start >= self.deadline_s:
                message = f"deadline {self.deadline_s:g} s reached after {generations} generations"
                break
            order = np.argsort(fitness)[::-1]
            elite = population[order[: self.elite]]
            n_children = self.population - self.elite
            contenders = rng.integers(0, self.population, size=(2, n_children, 2))
            winners = np.where(fitness[contenders[..., 0]] >= fitness[contenders[..., 1]],
                               contenders[..., 0], contenders[..., 1])
            children = self._offspring(population[winners[0]], population[winners[1]], eta, rng)
            child_fitness = score(children)
            evaluations += n_children
            population = np.concatenate([elite, children])
            fitness = np.concatenate([fitness[order[: self.elite]], child_fitness])
            generations += 1
            top = int(np.argmax(fitness))
            if fitness[top] > best_fitness:
                best_fitness, best_plan, stalled = float(fitness[top]), population[top].copy(), 0
            else:
                stalled += 1
                if self.stall is not None and stalled >= self.stall:
                    message = f"no improvement for {self.stall} generations; stopped after {generations}"
                    break
        cost, visible_steps = self.final_terms(problem, best_plan)
        elapsed = (now() - start) if now is not None else 0.0
        return PlanResult(
            success=bool(np.isfinite(best_fitness)),
            controls=best_plan,
            cost=cost,
            fitness=best_fitness,
            evaluations=evaluations,
            generations=generations,
            elapsed_s=elapsed,
            message=message,
            visible_steps=visible_steps,
        )

    def scorer(self, problem: PlanningProblem) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
        """The fitness of a population (P, V, T), higher is better: eq. (28)-(29)."""
        return lambda population: evaluate(problem, population).fitness

    def final_terms(self, problem: PlanningProblem, plan: NDArray[np.float64]) -> tuple[float, int]:
        """The best plan's cost ``J_rhc`` (eq. 20) and its vehicle-steps with the prediction visible."""
        final = evaluate(problem, plan[None])
        return float(final.j_rhc[0]), int(final.visible[0].sum())
