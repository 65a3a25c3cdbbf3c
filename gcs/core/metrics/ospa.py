"""Optimal sub-pattern assignment (OSPA) distance on sets of 2-D positions.

Schuhmacher, Vo & Vo, "A consistent metric for performance evaluation of
multi-object filters", IEEE Trans. Signal Processing 56(8), 2008, eq. (3): for
``X = {x_1..x_m}``, ``Y = {y_1..y_n}`` with ``m <= n`` (swap them otherwise), cut-off
``c > 0`` and order ``1 <= p < inf``,

.. math::
    \\bar d_p^{(c)}(X, Y) = \\Big( \\frac{1}{n} \\big( \\min_{\\pi \\in \\Pi_n}
        \\sum_{i=1}^{m} d^{(c)}(x_i, y_{\\pi(i)})^p + c^p (n - m) \\big) \\Big)^{1/p},
    \\qquad d^{(c)}(x, y) = \\min(c, \\lVert x - y \\rVert)

with ``bar d = 0`` when both sets are empty; for ``p = inf`` it is the largest
assigned cut-off distance when ``m = n`` and ``c`` otherwise.

Stone Soup's ``OSPAMetric`` (1.9) solves the assignment on ``d^{(c)}`` rather
than on ``(d^{(c)})^p``; both give the same value for ``p = 1`` and whenever the
two assignments agree, but for ``p > 1`` Stone Soup's value can be larger than the
minimum of eq. (3). ``assign_on_power=False`` reproduces Stone Soup's choice.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linear_sum_assignment

from gcs.core.metrics.gospa import check_parameters, as_points, cutoff_distances

__all__ = ["ospa"]


def ospa(estimates: ArrayLike, truths: ArrayLike, c: float, p: float = 2.0, assign_on_power: bool = True) -> float:
    """OSPA distance (metres) between estimated positions (m, 2) and true positions (n, 2).

    ``assign_on_power`` (default, eq. 3) minimises ``sum d^(c)^p``; False minimises
    ``sum d^(c)`` then sums the p-th powers of that assignment (Stone Soup 1.9).
    """
    check_parameters(c, p)
    x, y = as_points(estimates), as_points(truths)
    m, n = sorted((len(x), len(y)))
    if n == 0:
        return 0.0
    if m == 0:
        return float(c)
    dist = cutoff_distances(x, y, c)
    if not np.isfinite(p):
        if len(x) != len(y):
            return float(c)
        rows, cols = linear_sum_assignment(dist)
        return float(dist[rows, cols].max())
    cost = dist**p
    rows, cols = linear_sum_assignment(cost if assign_on_power else dist)
    total = cost[rows, cols].sum() + c**p * (n - m)  # eq. (3): the min over pi plus the cardinality penalty
    return float((total / n) ** (1.0 / p))
