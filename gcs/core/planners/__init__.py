"""Heading planners (Problem -> solve -> Result): the sight planner (the default), wang2012's GA receding-horizon
planner and baselines, zuo2021's one-step GCRLB-LM planner and its baselines.

:data:`PLANNER_CLASSES` maps each planner name a scenario or the command line gives
(:data:`gcs.core.planner_names.PLANNERS`, in that order) to the class that plans; the zuo2021 planners plan one heading
step and run in a tracker through :class:`OneStepHeadingPlanner`.
"""

from collections.abc import Mapping
from types import MappingProxyType

from gcs.core.planners.baselines import OrbitPlanner, PursuitPlanner
from gcs.core.planners.cross_entropy import CrossEntropyPlanner, SightGeneticPlanner
from gcs.core.planners.ga import GeneticPlanner, shift_plan
from gcs.core.planners.lm_gcrlb import (
    HeadingProblem, HeadingResult, LmGcrlbPlanner, StraightLinePlanner, Violations, crlb_planner,
)
from gcs.core.planners.one_step import OneStepHeadingPlanner
from gcs.core.planners.problem import CostBreakdown, PlanningProblem, PlanResult, RhcWeights, Visibility, evaluate
from gcs.core.planners.sequential import SightPlanner
from gcs.core.planners.sight import SightWeights

__all__ = [
    "CostBreakdown", "CrossEntropyPlanner", "GeneticPlanner", "HeadingProblem", "HeadingResult", "LmGcrlbPlanner",
    "OneStepHeadingPlanner", "OrbitPlanner", "PLANNER_CLASSES", "PlanResult", "PlanningProblem", "PursuitPlanner",
    "RhcWeights", "SightGeneticPlanner", "SightPlanner", "SightWeights", "StraightLinePlanner", "Violations",
    "Visibility", "crlb_planner", "evaluate", "shift_plan",
]

PLANNER_CLASSES: Mapping[str, type] = MappingProxyType({
    "sight": SightPlanner, "sight_k0": SightPlanner, "ga_k5": GeneticPlanner, "ga_k0": GeneticPlanner,
    "orbit": OrbitPlanner, "pursuit": PursuitPlanner,
    "sight_cem": CrossEntropyPlanner, "sight_ga": SightGeneticPlanner,
    "gcrlb_lm": LmGcrlbPlanner, "crlb_lm": LmGcrlbPlanner, "straight": StraightLinePlanner,
})
"""Each planner name (:data:`~gcs.core.planner_names.PLANNERS`) -> the class that plans (``crlb_lm`` is
:func:`crlb_planner`'s constant-noise :class:`LmGcrlbPlanner`)."""
