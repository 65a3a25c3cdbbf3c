"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""

from gcs.engine.tracking import SEARCH_VARIANTS
from gcs.engine.tracking import URBAN_PLANNERS as PLANNERS

__all__ = ["PLANNERS", "SEARCH_VARIANTS"]  # the planners of gcs bench urban (by default), and the other searches
