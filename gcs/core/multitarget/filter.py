"""Batched extended information filter over all tracks: one call per scan, no loop over tracks.

State of track ``t``: ``x_t = [x, y, vx, vy]`` (the ``cv2d`` layout of
:mod:`gcs.core.models.motion`, ENU metres and m/s), covariance ``P_t``; the
target moves on the plane at the sensor's ``target_height_m``. Shapes: means
(T, 4), covariances (T, 4, 4); a vehicle's detections (n, m).

Prediction (white-noise acceleration CV model, Bar-Shalom, Li & Kirubarajan
2001, section 6.2.2; wang2012 eq. 16-17)

.. math::
    x^- = F x, \\quad P^- = F P F^T + Q

Measurement prediction (EKF linearisation of wang2012 eq. 4 about ``x^-``,
analytic Jacobians of :class:`~gcs.core.models.sensor.SensorModel`), for every
track ``t`` and detection ``j`` of one vehicle:

.. math::
    \\nu_{tj} = z_j \\ominus h(x^-_t; s_j), \\quad
    R_{tj} = R(z) + J_{s} P_{s,j} J_{s}^T, \\quad
    S_{tj} = H_{tj} P^-_{t,pp} H_{tj}^T + R_{tj}

with ``\\ominus`` the azimuth-wrapping residual, ``H`` the Jacobian with respect
to the target's position (the velocity columns are zero), ``J_s`` that with
respect to the vehicle's position and ``P_s`` the vehicle's position covariance
(the inflation of :meth:`gcs.core.filters.uif.UnscentedInformationFilter.contribution`).

Update in information form (wang2012 eq. 14-15). Each vehicle ``v`` contributes
position-block information ``A_v`` (2, 2) and ``b_v = i_v - A_v p^-`` (2,) for
each track; for one associated detection (Bar-Shalom & Fortmann 1988, the
information filter) ``A_v = H^T R^{-1} H`` and ``b_v = H^T R^{-1} \\nu``. The sums
over vehicles are fused with the matrix inversion lemma, as in
:meth:`~gcs.core.filters.uif.UnscentedInformationFilter.update`:

.. math::
    A = \\sum_v A_v, \\; b = \\sum_v b_v, \\quad
    P = P^- - P^- E^T A (I_2 + P^-_{pp} A)^{-1} E P^-, \\quad x = x^- + P E^T b

with ``E = [I_2 \\; 0]``. The JPDA contributions (:func:`mixture_contributions`)
have the same form, so the fusion is the same for both association methods.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel

__all__ = ["Innovations", "predict", "innovations", "assigned_contributions", "mixture_contributions",
           "information_update"]

_EYE2 = np.eye(2)


@dataclass(frozen=True)
class Innovations:
    """Every track against every detection of one vehicle, linearised about the predictions.

    Attributes
    ----------
    nu : ndarray, shape (T, n, m)
        Innovations ``z_j - h(x_t)``, azimuth wrapped.
    h : ndarray, shape (T, n, m, 2)
        ``dh/dp`` at the predicted position (velocity columns are zero).
    r : ndarray, shape (T, n, m, m)
        Measurement noise, inflated by the vehicle's position uncertainty.
    s : ndarray, shape (T, n, m, m)
        Innovation covariances ``H P_pp H^T + R``.
    s_inv : ndarray, shape (T, n, m, m)
    d2 : ndarray, shape (T, n)
        Squared Mahalanobis distances ``nu^T S^-1 nu``.
    log_det_2pi_s : ndarray, shape (T, n)
        ``ln det(2 pi S)``: the Gaussian likelihood is ``exp(-(d2 + log_det_2pi_s) / 2)``.
    pairs : int
        The (track, detection) pairs evaluated: ``T n``, or those :func:`innovations` was given. A pair
        not evaluated has ``d2`` infinite (outside every gate) and zeros elsewhere.
    """

    nu: NDArray[np.float64]
    h: NDArray[np.float64]
    r: NDArray[np.float64]
    s: NDArray[np.float64]
    s_inv: NDArray[np.float64]
    d2: NDArray[np.float64]
    log_det_2pi_s: NDArray[np.float64]
    pairs: int

    @property
    def log_likelihood(self) -> NDArray[np.float64]:
        """``ln N(nu; 0, S)``, shape (T, n)."""
        return -0.5 * (self.d2 + self.log_det_2pi_s)


def predict(mean: NDArray[np.float64], cov: NDArray[np.float64], dt_s: float,
            motion: LinearMotionModel) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``x^- = F x``, ``P^- = F P F^T + Q`` for every track, one step of ``dt_s`` seconds.

    Parameters
    ----------
    mean : ndarray, shape (T, 4)
    cov : ndarray, shape (T, 4, 4)
    dt_s : float
        Step shared by the scan, > 0.
    motion : LinearMotionModel
        The ``cv2d`` model (white-noise acceleration).
    """
    if motion.name != "cv2d":
        raise ValueError(f"the multi-target filter runs the cv2d model, got {motion.name!r}")
    f, q = motion.matrices(dt_s)
    return mean @ f.T, f @ cov @ f.T + q


def innovations(mean: NDArray[np.float64], cov: NDArray[np.float64], sensor: SensorModel,
                z: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
                vehicle_cov: NDArray[np.float64],
                pairs: tuple[NDArray[np.int64], NDArray[np.int64]] | None = None) -> Innovations:
    """Innovations of T predicted tracks against n detections of one vehicle, vectorised (T, n).

    Parameters
    ----------
    mean, cov : ndarray, shapes (T, 4) and (T, 4, 4)
        Predicted tracks.
    z : ndarray, shape (n, m)
        Measurements in the sensor's component order.
    vehicle_xyz : ndarray, shape (n, 3)
        Where each detection was taken from (ENU m).
    vehicle_cov : ndarray, shape (n, 3, 3)
        Covariance of that position (zeros when exact).
    pairs : (rows, cols), optional
        Evaluate only these (track, detection) pairs
        (:func:`~gcs.core.multitarget.candidates.candidate_pairs`: those that can pass the gate);
        every pair when None.
    """
    t_count, n_count, m = mean.shape[0], z.shape[0], sensor.dim
    if pairs is None:
        rows = np.repeat(np.arange(t_count), n_count)
        cols = np.tile(np.arange(n_count), t_count)
    else:
        rows, cols = pairs
    nu, h, r, s, s_inv, d2, log_det = _pair_innovations(mean[rows], cov[rows], sensor, z[cols], vehicle_xyz[cols],
                                                        vehicle_cov[cols])
    if pairs is None:
        return Innovations(nu.reshape(t_count, n_count, m), h.reshape(t_count, n_count, m, 2),
                           r.reshape(t_count, n_count, m, m), s.reshape(t_count, n_count, m, m),
                           s_inv.reshape(t_count, n_count, m, m), d2.reshape(t_count, n_count),
                           log_det.reshape(t_count, n_count), rows.shape[0])
    dense = Innovations(np.zeros((t_count, n_count, m)), np.zeros((t_count, n_count, m, 2)),
                        np.zeros((t_count, n_count, m, m)), np.zeros((t_count, n_count, m, m)),
                        np.zeros((t_count, n_count, m, m)), np.full((t_count, n_count), np.inf),
                        np.zeros((t_count, n_count)), rows.shape[0])
    for whole, part in ((dense.nu, nu), (dense.h, h), (dense.r, r), (dense.s, s), (dense.s_inv, s_inv),
                        (dense.d2, d2), (dense.log_det_2pi_s, log_det)):
        whole[rows, cols] = part
    return dense


def _pair_innovations(mean: NDArray[np.float64], cov: NDArray[np.float64], sensor: SensorModel,
                      z: NDArray[np.float64], xyz: NDArray[np.float64], vehicle_cov: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], ...]:
    """``nu, h, r, s, s_inv, d2, ln det(2 pi S)`` of k pairs: track k against detection k (shapes (k, ...))."""
    p = mean[:, :2]
    z_pred = sensor.measure(p, xyz)  # (k, m)
    h = sensor.jacobian(p, xyz)  # (k, m, 2)
    r_diag = np.broadcast_to(sensor.noise_variance(z_pred, p, xyz), z_pred.shape)
    j_s = sensor.vehicle_jacobian(p, xyz)  # (k, m, 3)
    r = r_diag[..., None] * np.eye(sensor.dim) + j_s @ vehicle_cov @ j_s.swapaxes(-1, -2)
    s = h @ cov[:, :2, :2] @ h.swapaxes(-1, -2) + r
    s = 0.5 * (s + s.swapaxes(-1, -2))
    nu = sensor.residual(z, z_pred)
    if s.size:
        s_inv = np.linalg.inv(s)
        _, log_det = np.linalg.slogdet(2.0 * np.pi * s)
    else:
        s_inv, log_det = s.copy(), np.zeros(s.shape[:1])
    d2 = np.einsum("ki,kij,kj->k", nu, s_inv, nu)
    return nu, h, r, s, s_inv, d2, log_det


def assigned_contributions(inn: Innovations, assigned: NDArray[np.int64]
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Information of one detection per track: ``A = H^T R^-1 H``, ``b = H^T R^-1 nu`` (zero when unassigned).

    Parameters
    ----------
    inn : Innovations
        Of T tracks against n detections.
    assigned : ndarray of int, shape (T,)
        Detection index per track, -1 for none.

    Returns
    -------
    a : ndarray, shape (T, 2, 2)
    b : ndarray, shape (T, 2)
    """
    t_count = assigned.shape[0]
    a = np.zeros((t_count, 2, 2))
    b = np.zeros((t_count, 2))
    rows = np.flatnonzero(assigned >= 0)
    if rows.size == 0:
        return a, b
    cols = assigned[rows]
    h = inn.h[rows, cols]  # (k, m, 2)
    ht_rinv = np.linalg.solve(inn.r[rows, cols], h).swapaxes(-1, -2)  # H^T R^-1, R symmetric: (k, 2, m)
    a[rows] = ht_rinv @ h
    b[rows] = (ht_rinv @ inn.nu[rows, cols][..., None])[..., 0]
    return a, b


def mixture_contributions(inn: Innovations, beta: NDArray[np.float64], position_cov: NDArray[np.float64]
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Information equivalent of one vehicle's probabilistic (PDA/JPDA) update of every track.

    With ``beta_tj`` the association probabilities (``beta_t0 = 1 - sum_j beta_tj``
    the probability that no detection is the track's), the posterior of track
    ``t`` is the mixture of the prior (weight ``beta_t0``) and the Kalman
    updates with each detection, reduced to its mean and covariance (the PDA
    update, Bar-Shalom & Fortmann 1988; with one shared ``H`` and ``S`` it is
    their combined innovation ``sum_j beta_j nu_j`` and spread-of-innovations
    term). With ``g_j = H_j^T S_j^-1 nu_j`` and ``gbar = sum_j beta_j g_j``:

    .. math::
        x = x^- + P^- E^T \\bar g, \\quad P = P^- - P^- E^T C E P^-, \\quad
        C = \\sum_j \\beta_j H_j^T S_j^{-1} H_j
            - \\Big(\\sum_j \\beta_j g_j g_j^T - \\bar g \\bar g^T\\Big)

    (the bracket is the spread of innovations). By the matrix inversion lemma
    this posterior is the information update of :func:`information_update` with

    .. math::
        A = C (I_2 - P^-_{pp} C)^{-1}, \\quad b = (I_2 - C P^-_{pp})^{-1} \\bar g

    which for one detection with ``beta = 1`` is ``H^T R^-1 H`` and ``H^T R^-1 nu``
    again (push-through identity). ``A`` can be indefinite: the spread term
    widens the posterior beyond the prior along the line between detections.

    Parameters
    ----------
    inn : Innovations
        Of T tracks against n detections.
    beta : ndarray, shape (T, n)
        Marginal association probabilities, rows summing to <= 1.
    position_cov : ndarray, shape (T, 2, 2)
        ``P^-_pp``, the predicted position covariance.
    """
    rows, cols = np.nonzero(beta)  # the pairs that weigh: inside the gate, so evaluated
    weight = beta[rows, cols]
    h = inn.h[rows, cols]  # (k, m, 2)
    ht_sinv = h.swapaxes(-1, -2) @ inn.s_inv[rows, cols]  # (k, 2, m)
    g = (ht_sinv @ inn.nu[rows, cols][..., None])[..., 0]  # (k, 2)
    gbar = np.zeros((beta.shape[0], 2))
    np.add.at(gbar, rows, weight[:, None] * g)
    c = np.zeros((beta.shape[0], 2, 2))
    np.add.at(c, rows, weight[:, None, None] * (ht_sinv @ h - g[:, :, None] * g[:, None, :]))
    c = c + gbar[:, :, None] * gbar[:, None, :]
    left = _EYE2 - position_cov @ c  # I - P_pp C
    a = np.linalg.solve(left.swapaxes(-1, -2), c.swapaxes(-1, -2)).swapaxes(-1, -2)  # C (I - P_pp C)^-1
    a = 0.5 * (a + a.swapaxes(-1, -2))
    b = np.linalg.solve(left.swapaxes(-1, -2), gbar[..., None])[..., 0]  # (I - C P_pp)^-1 gbar
    return a, b


def information_update(mean: NDArray[np.float64], cov: NDArray[np.float64], a: NDArray[np.float64],
                       b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Fuse summed position information into every track (wang2012 eq. 14-15), without inverting ``Y``.

    Parameters
    ----------
    mean, cov : ndarray, shapes (T, 4) and (T, 4, 4)
        Predicted tracks.
    a : ndarray, shape (T, 2, 2)
        ``sum_v A_v``: eq. (14)'s ``sum_v I_v``, position block.
    b : ndarray, shape (T, 2)
        ``sum_v b_v = sum_v i_v - A p^-``.

    Returns
    -------
    mean, cov : ndarray, shapes (T, 4) and (T, 4, 4)
        ``x = x^- + P E^T b`` and ``P = P^- - P^- E^T A (I_2 + P_pp A)^-1 E P^-``.
    """
    p_cols = cov[:, :, :2]  # P^- E^T, (T, 4, 2)
    inner = _EYE2 + cov[:, :2, :2] @ a  # I + P_pp A
    gain = p_cols @ np.linalg.solve(inner.swapaxes(-1, -2), a.swapaxes(-1, -2)).swapaxes(-1, -2)
    post = cov - gain @ p_cols.swapaxes(-1, -2)  # eq. (15) by the inversion lemma
    post = 0.5 * (post + post.swapaxes(-1, -2))
    new_mean = mean + (post[:, :, :2] @ b[..., None])[..., 0]
    return new_mean, post
