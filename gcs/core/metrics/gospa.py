"""Generalised optimal sub-pattern assignment (GOSPA) metric, alpha = 2, on sets of 2-D positions.

Rahmathullah, Garcia-Fernandez & Svensson, "Generalized optimal sub-pattern
assignment metric", 20th Int. Conf. on Information Fusion, 2017 (arXiv:1601.05585).
For an estimate set ``X = {x_1..x_m}`` and a truth set ``Y = {y_1..y_n}``, cut-off
``c > 0``, order ``1 <= p < inf`` and ``alpha = 2``, Proposition 1 of the paper writes
GOSPA as an optimisation over assignment sets ``gamma`` (pairs ``(i, j)`` with
``d(x_i, y_j) < c``, each index used at most once):

.. math::
    d_p^{(c, 2)}(X, Y) = \\Big( \\min_{\\gamma} \\sum_{(i, j) \\in \\gamma} d(x_i, y_j)^p
        + \\frac{c^p}{2} \\big(|X| - |\\gamma|\\big) + \\frac{c^p}{2} \\big(|Y| - |\\gamma|\\big) \\Big)^{1/p}

so that the p-th power splits into a **localisation** part (the assigned pairs'
``d^p``), a **missed** part (``c^p / 2`` per unassigned truth) and a **false** part
(``c^p / 2`` per unassigned estimate). The minimum equals the one over permutations
of the cut-off distance ``d^{(c)} = min(d, c)`` (Definition 1 of the paper): a
pair at ``d >= c`` costs ``c^p``, exactly one missed plus one false, so it is
solved as a rectangular assignment on ``min(d, c)^p`` and pairs at the cut-off are
then counted as missed and false.

Conventions (the same as Stone Soup's ``GOSPAMetric`` with ``switching_penalty=0``,
which the tests check): ``distance`` is raised to ``1/p``; ``localisation``,
``missed`` and ``false`` are NOT (they are the three terms of ``distance ** p``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["GospaResult", "cutoff_distances", "gospa", "as_points", "check_parameters"]


def as_points(points: ArrayLike) -> NDArray[np.float64]:
    """A set of 2-D positions as float64 (k, 2); an empty input gives (0, 2)."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"a set of positions must have shape (k, 2), got {arr.shape}")
    return arr


def cutoff_distances(estimates: NDArray[np.float64], truths: NDArray[np.float64], c: float) -> NDArray[np.float64]:
    """Cut-off Euclidean distances ``min(||x_i - y_j||, c)``, shape (m, n), for estimates (m, 2), truths (n, 2)."""
    diff = estimates[:, None, :] - truths[None, :, :]
    distances: NDArray[np.float64] = np.minimum(np.sqrt(np.einsum("mnk,mnk->mn", diff, diff)), c)
    return distances


def check_parameters(c: float, p: float) -> None:
    """Raise ValueError unless the cut-off ``c`` is finite and positive and the order ``p >= 1`` (may be inf)."""
    if not (c > 0 and np.isfinite(c)):
        raise ValueError(f"the cut-off c must be finite and > 0, got {c!r}")
    if not (p >= 1):
        raise ValueError(f"the order p must be >= 1, got {p!r}")


@dataclass(frozen=True)
class GospaResult:
    """GOSPA at one time step.

    ``distance = (localisation + missed + false) ** (1/p)``; the three parts are in
    metres**p. ``assignment`` (n,) gives, for each truth, the index of its estimate
    (``d < c``) or -1; ``missed_count`` / ``false_count`` are the unassigned truths
    and estimates.
    """

    distance: float
    localisation: float
    missed: float
    false: float
    assignment: NDArray[np.int64]
    missed_count: int
    false_count: int


def gospa(estimates: ArrayLike, truths: ArrayLike, c: float, p: float = 2.0) -> GospaResult:
    """GOSPA with ``alpha = 2`` between estimated positions (m, 2) and true positions (n, 2), metres.

    Parameters
    ----------
    estimates, truths : array_like, shapes (m, 2) and (n, 2)
        Either may be empty.
    c : float
        Cut-off distance, metres.
    p : float
        Order, ``1 <= p < inf``.
    """
    check_parameters(c, p)
    if not np.isfinite(p):
        raise ValueError("GOSPA needs a finite order p")
    x, y = as_points(estimates), as_points(truths)
    m, n = len(x), len(y)
    assignment = np.full(n, -1, dtype=np.int64)
    localisation = 0.0
    if m and n:
        cost = cutoff_distances(x, y, c) ** p
        rows, cols = linear_sum_assignment(cost)  # min over gamma of Proposition 1, as Definition 1's permutation
        inside = cost[rows, cols] < c**p  # pairs at the cut-off are one missed plus one false
        assignment[cols[inside]] = rows[inside]
        localisation = float(cost[rows[inside], cols[inside]].sum())
    assigned = int((assignment >= 0).sum())
    half = c**p / 2.0  # c^p / alpha with alpha = 2
    missed, false = half * (n - assigned), half * (m - assigned)
    distance = (localisation + missed + false) ** (1.0 / p)
    return GospaResult(float(distance), localisation, float(missed), float(false), assignment, n - assigned,
                       m - assigned)
