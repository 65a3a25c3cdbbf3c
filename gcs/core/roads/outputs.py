"""What the road trackers give the rest of the system: a Gaussian summary, and the horizon as weighted samples.

**Point estimate.** A road-constrained posterior is a mixture (of particles, or of
Gaussian components on branches). Its summary is the moment-matched Gaussian
on ``[x, y, vx, vy]`` (the ``cv2d`` layout):

.. math::
    \\bar x = \\sum_i w_i x_i, \\qquad
    P = \\sum_i w_i \\big(P_i + (x_i - \\bar x)(x_i - \\bar x)^T\\big)

(``P_i = 0`` for a particle), plus :data:`MIN_VARIANCE_M2` on the diagonal, so that a
cloud collapsed onto a point or a line (a straight road) still has an invertible
covariance. ``\\bar x`` is the minimum mean-square-error
estimate, the point scored in the benchmarks; between two branches it can lie
off the road, which is why :class:`RoadHorizon` also carries the branches.

**Horizon.** :class:`RoadHorizon` is a :class:`~gcs.core.filters.prediction.HorizonPrediction`
(the moment-matched states at k+1..k+n, for planners that take Gaussians) that
also carries weighted position samples ``(T, S, 2)`` with weights ``(T, S)``
summing to 1 per step: the sight objective's samples, weighted by branch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import GaussianEstimate, check_stamp_ns
from gcs.core.filters.prediction import HorizonPrediction

__all__ = ["RoadHorizon", "moment_match", "normalise_log_weights", "forward_stamp", "MIN_VARIANCE_M2"]

MIN_VARIANCE_M2 = 1.0
"""Added to the summary's position and velocity variances (m^2, m^2/s^2): a cloud collapsed onto a point, or
onto a line along a road, keeps a positive-definite covariance."""


def moment_match(weights: NDArray[np.float64], states: NDArray[np.float64],
                 covs: NDArray[np.float64] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean (..., n) and covariance (..., n, n) of a mixture: weights (..., C) summing to 1, states (..., C, n),
    component covariances (..., C, n, n) or None for points (module docstring)."""
    mean = np.einsum("...c,...cn->...n", weights, states)
    d = states - mean[..., None, :]
    cov = np.einsum("...c,...cn,...cm->...nm", weights, d, d)
    if covs is not None:
        cov = cov + np.einsum("...c,...cnm->...nm", weights, covs)
    diagonal = np.arange(states.shape[-1])
    cov[..., diagonal, diagonal] += MIN_VARIANCE_M2
    return mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))


def forward_stamp(estimate: GaussianEstimate, stamp_ns: int) -> int:
    """``stamp_ns`` checked (an integer, not before the estimate's); TypeError or ValueError otherwise."""
    stamp_ns = check_stamp_ns(stamp_ns)
    if stamp_ns < estimate.stamp_ns:
        raise ValueError(f"cannot predict backwards from {estimate.stamp_ns} ns to {stamp_ns} ns")
    return stamp_ns


def normalise_log_weights(log_w: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """Log-weights shifted to sum to 1 in the linear domain, and the log of their former sum (-inf if all -inf)."""
    top = float(np.max(log_w))
    if not np.isfinite(top):
        return np.full_like(log_w, -np.log(len(log_w))), -np.inf
    total = top + float(np.log(np.exp(log_w - top).sum()))
    return log_w - total, total


@dataclass(frozen=True)
class RoadHorizon(HorizonPrediction):
    """The k+1..k+n prediction: moment-matched ``states`` (T, 4), and ``samples`` (T, S, 2) with ``weights`` (T, S).

    ``off_road`` (T,) is the predicted probability of the off-road mode at each step. A road tracker gives
    each step's samples grouped by branch (all those of one edge together), so that thinning them
    systematically (:func:`gcs.core.planners.sight.thinned`) keeps every branch's weight.
    """

    samples: NDArray[np.float64] | None = None
    weights: NDArray[np.float64] | None = None
    off_road: NDArray[np.float64] | None = None

    @classmethod
    def from_samples(cls, stamps_ns: tuple[int, ...], states: NDArray[np.float64], weights: NDArray[np.float64],
                     off_road: NDArray[np.float64], covs: NDArray[np.float64] | None = None) -> RoadHorizon:
        """From per-step states (T, S, 4) (and covariances (T, S, 4, 4)) with weights (T, S)."""
        mean, cov = moment_match(weights, states, covs)
        return cls(stamps_ns, GaussianEstimate(mean, cov, stamps_ns[0]), states[..., :2].copy(), weights, off_road)
