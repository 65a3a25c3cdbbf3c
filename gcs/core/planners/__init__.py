"""Heading planners: wang2012's GA receding-horizon planner and baselines (Problem -> solve -> Result)."""

from gcs.core.planners.baselines import OrbitPlanner, PursuitPlanner
from gcs.core.planners.ga import GeneticPlanner, shift_plan
from gcs.core.planners.problem import CostBreakdown, PlanningProblem, PlanResult, RhcWeights, Visibility, evaluate

__all__ = [
    "CostBreakdown", "GeneticPlanner", "OrbitPlanner", "PlanResult", "PlanningProblem", "PursuitPlanner",
    "RhcWeights", "Visibility", "evaluate", "shift_plan",
]
