"""k+n prediction (wang2012 eq. 16-17) and expected information of candidate vehicle states (eq. 18).

From the fused posterior at step k the first prediction is the filter's
unscented prediction (eq. 16); the paper then propagates the mean with the
motion model alone, ``x[k+j]^- = F(x[k+j-1]^-)`` (eq. 17). We carry the
covariance along as well, ``P[k+j]^- = F P[k+j-1]^- F^T + Q``, because the
pseudo-measurement matrix of eq. (18) is computed from sigma points of that
prediction, and because its growth says how far ahead a plan can trust it.

Expected information (eq. 18): for a candidate vehicle position ``x_i[k+j]``
the information a detection would bring is
``I_i[k+j]^- = (H^p[k+j]^-)^T R^-1 H^p[k+j]^-`` with ``H^p`` the
pseudo-measurement matrix of eq. (12) evaluated at the predicted target state
and the candidate position. :func:`expected_information` evaluates it for any
batch of candidates at once, e.g. a GA population x vehicles x horizon.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.uif import NS_PER_S, GaussianEstimate, UnscentedInformationFilter, pseudo_measurement
from gcs.core.models.sensor import SensorModel

__all__ = ["HorizonPrediction", "predict_horizon", "expected_information"]


@dataclass(frozen=True)
class HorizonPrediction:
    """Predicted target states at k+1..k+n.

    ``states`` is a stacked estimate: mean (n_steps, n) and covariance
    (n_steps, n, n); its ``stamp_ns`` is the first step's. ``stamps_ns`` holds
    every step's time.
    """

    stamps_ns: tuple[int, ...]
    states: GaussianEstimate

    @property
    def positions(self) -> NDArray[np.float64]:
        """Predicted ENU positions, shape (n_steps, 2)."""
        return self.states.mean[:, :2]


def predict_horizon(
    uif: UnscentedInformationFilter, posterior: GaussianEstimate, step_s: float, steps: int
) -> HorizonPrediction:
    """Predict ``steps`` decision steps of ``step_s`` seconds ahead (eq. 16-17)."""
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    step_ns = int(round(step_s * NS_PER_S))
    # Eq. (16) is eq. (17)'s first step: the linear motion model's prediction of one step.
    powers, noises = uif.motion.horizon_matrices(step_ns / NS_PER_S, steps)
    means = powers @ posterior.mean
    covs = powers @ posterior.cov @ powers.swapaxes(-1, -2) + noises
    stamps = tuple(posterior.stamp_ns + j * step_ns for j in range(1, steps + 1))
    return HorizonPrediction(stamps, GaussianEstimate(means, covs, stamps[0]))


def expected_information(
    uif: UnscentedInformationFilter,
    prediction: HorizonPrediction,
    sensor: SensorModel,
    candidate_xyz: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Expected information of a detection from each candidate position (eq. 18).

    Parameters
    ----------
    prediction : HorizonPrediction
        The k+1..k+n predictions (n_steps of them).
    candidate_xyz : ndarray, shape (..., n_steps, 3)
        Candidate vehicle ENU positions at each predicted step; any leading axes
        (population, vehicles) are kept.

    Returns
    -------
    ndarray, shape (..., n_steps, 2, 2)
        ``(H^p)^T R^-1 H^p`` restricted to the target's position (x, y); the
        other rows and columns of eq. (18) are zero.
    """
    candidate_xyz = np.asarray(candidate_xyz, dtype=np.float64)
    z_pred, h_pos = pseudo_measurement(prediction.states, sensor, candidate_xyz, uif.sigma)
    r_inv = 1.0 / uif.noise_variance(prediction.states, sensor, z_pred, candidate_xyz)  # the filter's R (eq. 13)
    ht_rinv = h_pos.swapaxes(-1, -2) * r_inv[..., None, :]
    information: NDArray[np.float64] = ht_rinv @ h_pos
    return information
