"""Heading planners (Problem -> solve -> Result): wang2012's GA receding-horizon planner and baselines,
zuo2021's one-step GCRLB-LM planner and its baselines."""

from gcs.core.planners.baselines import OrbitPlanner, PursuitPlanner
from gcs.core.planners.ga import GeneticPlanner, shift_plan
from gcs.core.planners.lm_gcrlb import (
    HeadingProblem, HeadingResult, LmGcrlbPlanner, StraightLinePlanner, Violations, crlb_planner,
)
from gcs.core.planners.one_step import OneStepHeadingPlanner
from gcs.core.planners.problem import CostBreakdown, PlanningProblem, PlanResult, RhcWeights, Visibility, evaluate

__all__ = [
    "CostBreakdown", "GeneticPlanner", "HeadingProblem", "HeadingResult", "LmGcrlbPlanner", "OneStepHeadingPlanner", "OrbitPlanner",
    "PlanResult", "PlanningProblem", "PursuitPlanner", "RhcWeights", "StraightLinePlanner", "Violations",
    "Visibility", "crlb_planner", "evaluate", "shift_plan",
]
