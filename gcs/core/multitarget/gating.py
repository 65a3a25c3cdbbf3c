"""Chi-square validation gate on the innovation's Mahalanobis distance, every track x detection at once.

A detection ``j`` is validated for track ``t`` when (Bar-Shalom & Fortmann 1988,
the validation region; Blackman & Popoli 1999, the ellipsoidal gate)

.. math::
    d^2_{tj} = \\nu_{tj}^T S_{tj}^{-1} \\nu_{tj} \\le \\gamma, \\qquad
    \\gamma = F^{-1}_{\\chi^2_m}(P_G)

where ``m`` is the measurement dimension and ``P_G`` the gate probability: the
probability that the target's own detection, if the linear-Gaussian model holds,
falls inside the gate. ``P_G`` enters the JPDA event probabilities
(:mod:`gcs.core.multitarget.jpda`) through ``1 - P_D P_G``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

__all__ = ["gate_threshold", "gate"]


@lru_cache(maxsize=64)
def gate_threshold(probability: float, dim: int) -> float:
    """``gamma``: the ``probability`` quantile of the chi-square distribution with ``dim`` degrees of freedom."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"gate probability must be in (0, 1), got {probability!r}")
    if dim < 1:
        raise ValueError(f"measurement dimension must be >= 1, got {dim}")
    return float(chi2.ppf(probability, dim))


def gate(d2: NDArray[np.float64], probability: float, dim: int) -> NDArray[np.bool_]:
    """Validation matrix (T, n): True where ``d2[t, j] <= gamma`` (NaN distances are outside)."""
    return np.asarray(d2 <= gate_threshold(probability, dim))
