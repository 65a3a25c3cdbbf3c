"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""

from gcs.core.planner_names import SEARCH_VARIANTS
from gcs.core.planner_names import URBAN_PLANNERS as PLANNERS

__all__ = ["PLANNERS", "SEARCH_VARIANTS"]  # the planners of gcs bench urban (by default), and the other searches
