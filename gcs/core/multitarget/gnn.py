"""Gated global nearest neighbour: the most likely single assignment of one vehicle's detections.

Each track takes at most one detection and each detection at most one track
(Blackman & Popoli 1999, global nearest neighbour; the optimal 2-D assignment).
The cost of pairing track ``t`` with a validated detection ``j`` is the negative
log-likelihood ratio of "``j`` is ``t``'s detection" against "``t`` was missed
and ``j`` is clutter":

.. math::
    c_{tj} = -\\ln \\frac{P_D \\, \\mathcal N(\\nu_{tj}; 0, S_{tj})}{\\lambda \\, (1 - P_D P_G)}
           = \\tfrac12 d^2_{tj} + \\tfrac12 \\ln\\det(2\\pi S_{tj})
             - \\ln P_D + \\ln \\lambda + \\ln(1 - P_D P_G)

with ``lambda`` the clutter's spatial density (false detections per unit volume
of measurement space) and leaving a track unassigned costing 0. These are the
factors of a joint event's probability in the JPDA
(:mod:`gcs.core.multitarget.jpda`), so the assignment that minimises the summed
cost is the most probable feasible joint event. Pairs outside the gate cost
``+inf``. The problem is solved by :func:`scipy.optimize.linear_sum_assignment`
on the T x (n + T) matrix ``[c | D]`` whose extra columns are one "missed"
column per track (``D`` is 0 on the diagonal, ``+inf`` elsewhere), which makes
every instance feasible.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["assignment_costs", "gnn_assign"]


def assignment_costs(log_likelihood: NDArray[np.float64], valid: NDArray[np.bool_], detection_probability: float,
                     gate_probability: float, clutter_density: float) -> NDArray[np.float64]:
    """``c_tj`` (T, n) for validated pairs, ``+inf`` for the rest.

    Parameters
    ----------
    log_likelihood : ndarray, shape (T, n)
        ``ln N(nu_tj; 0, S_tj)`` (:attr:`Innovations.log_likelihood`).
    valid : ndarray of bool, shape (T, n)
        The gate (:func:`gcs.core.multitarget.gating.gate`).
    detection_probability, gate_probability : float
        ``P_D`` and ``P_G``.
    clutter_density : float
        ``lambda`` > 0, per unit of measurement-space volume.
    """
    if not clutter_density > 0.0:
        raise ValueError(f"clutter density must be > 0, got {clutter_density!r}")
    offset = math.log(clutter_density) + math.log1p(-detection_probability * gate_probability) \
        - math.log(detection_probability)
    return np.where(valid, offset - log_likelihood, np.inf)


def gnn_assign(costs: NDArray[np.float64]) -> NDArray[np.int64]:
    """The assignment of least total cost: detection index per track (T,), -1 for a track left unassigned.

    A track takes a detection only when that lowers the total, i.e. never a pair
    whose cost is ``+inf`` and, alone, only a pair of negative cost.
    """
    t_count, n_count = costs.shape
    assigned = np.full(t_count, -1, dtype=np.int64)
    if t_count == 0 or n_count == 0 or not np.isfinite(costs).any():
        return assigned
    missed = np.full((t_count, t_count), np.inf)
    np.fill_diagonal(missed, 0.0)
    rows, cols = linear_sum_assignment(np.hstack([costs, missed]))
    real = cols < n_count
    assigned[rows[real]] = cols[real]
    return assigned
