"""The benchmarks: the papers' experiments reproduced, the peers measured beside our code, and speed (``gcs-bench``).

A package of its own above every shell of the ground station (``pyproject.toml``,
``[tool.importlinter]``): it drives the product as its users do, and nothing of
``gcs`` imports it. Each benchmark computes in its module and registers its
command in :mod:`benchmarks.arguments`; :mod:`benchmarks.cli` is ``gcs-bench``.
"""

from gcs.core.planner_names import SEARCH_VARIANTS
from gcs.core.planner_names import URBAN_PLANNERS as PLANNERS

__all__ = ["PLANNERS", "SEARCH_VARIANTS"]  # the planners of gcs-bench urban (by default), and the other searches
