"""How a track is lost, and how honest its covariance is: the figures ``gcs-bench urban`` and ``gcs-bench roads``
report beside the RMSE.

With ``e_k`` the distance from the scored point estimate to the target at step ``k``, pooled over
the steps with a track of every run:

* the error's 95th percentile and maximum;
* the steps with ``e_k > 50 m`` and ``> 100 m``, and the runs with any;
* the share of steps whose position NEES ``e^T P_pp^-1 e`` (2 degrees of freedom) lies inside its
  95% band ``[chi2_2(0.025), chi2_2(0.975)]`` (:data:`NEES_BAND`): a consistent filter scores 0.95,
  an overconfident one less, with NEES above the band;
* the longest stretch of steps in a row that no UAV saw the target (:func:`longest_unseen`), a
  property of the run's flight.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

__all__ = ["NEES_BAND", "LOST_THRESHOLDS_M", "error_figures", "nees_inside", "longest_unseen"]

NEES_BAND = (float(chi2.ppf(0.025, 2)), float(chi2.ppf(0.975, 2)))
LOST_THRESHOLDS_M = (50.0, 100.0)


def error_figures(errors_by_run: Sequence[NDArray[np.float64]]) -> dict:
    """The error's p95 and maximum, and the steps and runs over each of :data:`LOST_THRESHOLDS_M`, pooled over the
    runs' steps with a track (NaN: no track; left out)."""
    runs = [np.asarray(e, dtype=np.float64)[np.isfinite(e)] for e in errors_by_run]
    pooled = np.concatenate(runs) if runs else np.zeros(0)
    out: dict = {"steps": int(pooled.size),
                 "p95_m": float(np.percentile(pooled, 95)) if pooled.size else float("nan"),
                 "max_m": float(pooled.max()) if pooled.size else float("nan")}
    for threshold in LOST_THRESHOLDS_M:
        out[f"steps_over_{threshold:.0f}"] = int((pooled > threshold).sum())
        out[f"runs_over_{threshold:.0f}"] = int(sum(bool((e > threshold).any()) for e in runs))
    return out


def nees_inside(nees: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which NEES values (2 degrees of freedom) lie inside :data:`NEES_BAND`; NaN (no track) is not inside."""
    nees = np.asarray(nees, dtype=np.float64)
    return (nees >= NEES_BAND[0]) & (nees <= NEES_BAND[1])


def longest_unseen(seen_any: NDArray[np.bool_]) -> int:
    """Most consecutive steps at which no UAV saw the target (``seen_any`` per step)."""
    longest = current = 0
    for seen in np.asarray(seen_any, dtype=bool):
        current = 0 if seen else current + 1
        longest = max(longest, current)
    return longest
