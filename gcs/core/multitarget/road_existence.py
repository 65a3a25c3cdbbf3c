"""The probability that a road track is a target's: integrated probabilistic data association (IPDA).

Musicki, Evans and Stankovic, "Integrated probabilistic data association",
IEEE Transactions on Automatic Control 39(6), 1994. Track ``t`` exists with
probability ``r_t``. Between scans a target stays with probability
``p_s`` a second, ``r^- = p_s^{dt} r``. A vehicle's scan then multiplies the odds
of existence by the likelihood ratio of its detections given the target against
given no target (all clutter):

.. math::
    \\Lambda_t = m_t + \\sum_j \\frac{a_{tj}}{\\lambda}, \\qquad
    r_t = \\frac{\\Lambda_t r^-_t}{1 - r^-_t + \\Lambda_t r^-_t}

with ``m_t`` and ``a_tj`` the cloud's averages of :mod:`~gcs.core.multitarget.road_association`
(the probability that the vehicle missed the target, and the detection
likelihoods times the detection probability, over the gated detections ``j``;
GNN counts its assigned detection only). This is IPDA's
``r = (1 - delta) r^- / (1 - delta r^-)``, ``delta = 1 - Lambda``, with a detection
probability that depends on where the target is: a vehicle that had the whole
cloud in sight and detected nothing (``m_t`` near ``1 - P_D``) divides the odds by
ten, one that saw none of it (``m_t`` near 1) leaves them. A track whose
existence falls under a bound is deleted: the track a UAV keeps looking at
and finding empty, wherever its particles hide.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.multitarget.road_association import ParticleTerms, log_sum

__all__ = ["predicted_existence", "existence_log_ratio", "updated_existence"]


def predicted_existence(existence: NDArray[np.float64], survival_per_s: float, dt_s: float) -> NDArray[np.float64]:
    """``r^- = p_s^dt r`` (T,)."""
    predicted: NDArray[np.float64] = existence * survival_per_s**dt_s
    return predicted


def existence_log_ratio(terms: ParticleTerms, counted: NDArray[np.bool_], clutter_density: float
                        ) -> NDArray[np.float64]:
    """``ln Lambda_t`` (T,) of one vehicle's scan, the detections ``counted`` (T, n) included (module docstring)."""
    detected = np.where(counted, terms.log_a - np.log(clutter_density), -np.inf)
    return log_sum(np.concatenate([terms.log_m[:, None], detected], axis=1), 1)


def updated_existence(existence: NDArray[np.float64], log_ratio: NDArray[np.float64]) -> NDArray[np.float64]:
    """``r = Lambda r^- / (1 - r^- + Lambda r^-)`` (T,), in odds: ``ln o = ln o^- + ln Lambda``."""
    with np.errstate(divide="ignore"):
        log_odds = np.log(existence) - np.log1p(-existence) + log_ratio
    updated: NDArray[np.float64] = np.where(existence >= 1.0, 1.0, 1.0 / (1.0 + np.exp(-log_odds)))
    return updated
