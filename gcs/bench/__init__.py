"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""

from gcs.tracking import URBAN_PLANNERS as PLANNERS

__all__ = ["PLANNERS"]  # the planners of gcs bench urban
