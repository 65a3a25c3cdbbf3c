"""The measurement update of many Gaussian components at once, each seeing the target through a linear position map.

Component ``c`` has state ``x_c`` (n,) ~ N(m_c, P_c) and places the target at

.. math::
    p_c(x) = a_c + B_c x \\qquad (a_c \\in R^2,\\ B_c \\in R^{2 \\times n})

(on a road edge ``a`` is the edge's tail node, ``x = (s, v)`` and ``B = [d_e \\; 0]``;
off the road ``a = 0`` and ``B = [I_2 \\; 0]`` on ``[x, y, vx, vy]``). Every detection
of the step is stacked into one measurement vector ``z`` (the DUIF's sum of the
vehicles' information contributions, wang2012 eq. 14, is the same update in
information form), and the update is the iterated extended Kalman filter
(Bell and Cathey 1993) on it: about the current iterate ``x^i``,

.. math::
    H = \\frac{\\partial h}{\\partial p}\\Big|_{p_c(x^i)} B_c, \\quad
    S = H P H^T + R, \\quad K = P H^T S^{-1}, \\quad
    x^{i+1} = m + K\\big(z \\ominus h(p_c(x^i)) - H (m - x^i)\\big)

with the analytic Jacobian of eq. (4) (:meth:`SensorModel.jacobian`), ``R``
diagonal: the sensor's noise (zuo2021 eq. 2), the vehicles' own position
variance and the component's lateral spread ``sigma_l`` (isotropic terms,
:meth:`SensorModel.isotropic_vehicle_variance`), and the second-order term the
linearisation leaves out (:meth:`SensorModel.linearisation_variance`, as the
DUIF's ``second_order``). ``ITERATIONS`` Gauss-Newton steps; the posterior
covariance is ``(I - K H) P`` at the last. The component's marginal likelihood
``N(z \\ominus h(p_c(m)); 0, S)`` about the prior mean reweighs the mixture.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.roads.sensing import DetectionGroup, per_axis_vehicle_variance

__all__ = ["update_components", "ITERATIONS"]

ITERATIONS = 3
"""Linearisations per update (1 is the plain EKF)."""
_LOG_2PI = math.log(2.0 * math.pi)


def _measurements(points: NDArray[np.float64], groups: Sequence[DetectionGroup], position_cov: NDArray[np.float64],
                  spread_var_m2: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Stacked predicted measurements (C, M), residuals (C, M), Jacobians (C, M, 2) and noise variances (C, M)."""
    preds: list[NDArray[np.float64]] = []
    residuals: list[NDArray[np.float64]] = []
    jacobians: list[NDArray[np.float64]] = []
    noises: list[NDArray[np.float64]] = []
    for sensor, z, xyz, covs in groups:
        z = np.asarray(z, dtype=np.float64).reshape(-1, sensor.dim)
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        p, v = points[:, None, :], xyz[None, :, :]
        pred = sensor.measure(p, v)  # (C, k, m)
        r = sensor.noise_variance(pred, p, v) + sensor.linearisation_variance(p, v, position_cov[:, None])
        extra = per_axis_vehicle_variance(covs, len(xyz)) + spread_var_m2
        r = r + sensor.isotropic_vehicle_variance(p, v, extra[None, :])
        c, k, m = pred.shape
        preds.append(pred.reshape(c, k * m))
        residuals.append(sensor.residual(z[None], pred).reshape(c, k * m))
        jacobians.append(sensor.jacobian(p, v).reshape(c, k * m, 2))
        noises.append(np.broadcast_to(r, pred.shape).reshape(c, k * m))
    return (np.concatenate(preds, 1), np.concatenate(residuals, 1), np.concatenate(jacobians, 1),
            np.concatenate(noises, 1))


def update_components(mean: NDArray[np.float64], cov: NDArray[np.float64], offset: NDArray[np.float64],
                      basis: NDArray[np.float64], groups: Sequence[DetectionGroup], spread_var_m2: float = 0.0
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Posterior means (C, n) and covariances (C, n, n), log-likelihoods (C,) and normalised squared innovations
    (C,) of C components (module docstring) given the step's detections.

    Parameters
    ----------
    mean, cov : ndarray, shapes (C, n) and (C, n, n)
    offset, basis : ndarray, shapes (C, 2) and (C, 2, n)
        ``p = offset + basis @ x``.
    """
    position_cov = basis @ cov @ basis.swapaxes(-1, -2) + spread_var_m2 * np.eye(2)
    iterate = mean
    for i in range(ITERATIONS):
        points = offset + np.einsum("cpn,cn->cp", basis, iterate)
        _, nu, jac, r = _measurements(points, groups, position_cov, spread_var_m2)
        h = jac @ basis  # (C, M, n)
        s = h @ cov @ h.swapaxes(-1, -2) + r[:, :, None] * np.eye(r.shape[1])
        gain = np.linalg.solve(s, h @ cov).swapaxes(-1, -2)  # P H^T S^-1 (S symmetric): (C, n, M)
        if i == 0:
            sign, log_det = np.linalg.slogdet(s)
            d2 = np.einsum("cm,cm->c", nu, np.linalg.solve(s, nu[..., None])[..., 0])
            log_lik = np.where(sign > 0, -0.5 * (d2 + log_det + nu.shape[1] * _LOG_2PI), -np.inf)
        correction = nu - np.einsum("cmn,cn->cm", h, mean - iterate)
        iterate = mean + np.einsum("cnm,cm->cn", gain, correction)
    posterior = cov - gain @ h @ cov
    return iterate, 0.5 * (posterior + posterior.swapaxes(-1, -2)), log_lik, d2
