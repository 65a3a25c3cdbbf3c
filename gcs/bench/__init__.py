"""Reproductions of the papers' experiments and speed benchmarks (``gcs bench ...``)."""

from gcs.tracking import PLANNERS

__all__ = ["PLANNERS"]
