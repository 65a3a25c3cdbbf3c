"""Unscented information filter (UIF) and its distributed fusion (DUIF), wang2012 section 3.

Information form (eq. 7): ``y = P^-1 x``, ``Y = P^-1``.

Prediction (eq. 9, 11, 16). The sigma points ``chi^j`` of the posterior are passed
through the motion model, ``x^- = sum_j W_m^j chi^j``, ``P^- = sum_j W_c^j
(chi^j - x^-)(chi^j - x^-)^T + Q``, then ``Y^- = (P^-)^-1`` and ``y^- = Y^- x^-``.
The target models are linear (:mod:`gcs.core.models.motion`), for which that
transform equals ``F x`` and ``F P F^T + Q`` exactly, so the closed form is used.

Measurement contribution (eq. 12-13, Lee 2008/2009). Sigma points are drawn from
the prediction; with ``Z^j = H(chi^j)``, ``z^- = sum_j W_m^j Z^j`` and the
cross-covariance ``P_xz = sum_j W_c^j (chi^j - x^-)(Z^j - z^-)^T``, the
statistically linearised measurement matrix is

.. math::
    H^p = (Y^- P_{xz})^T = P_{xz}^T Y^-

and the measurement is approximated by ``z ~ H^p x + u`` with
``u = z^- - H^p x^-`` (eq. 12). Its information contribution is

.. math::
    i = (H^p)^T R^{-1} \\big(\\nu + H^p x^-\\big), \\quad I = (H^p)^T R^{-1} H^p, \\quad
    \\nu = z - z^-                                                          \\qquad (13)

with the azimuth part of ``nu`` wrapped.

Computation. With ``P^- = L L^T`` (Cholesky) the sigma-point offsets are
``chi^j - x^- = +-c L e_j`` with ``c = sqrt(n + lambda)``, and the centre point has
no offset, so ``P_xz = (c / (2 (n + lambda))) L D`` where row j of ``D`` (n x m)
is ``Z^j - Z^{n+j}``. Hence, exactly,

.. math::
    H^p = P_{xz}^T Y^- = \frac{1}{2c} D^T L^{-1}

which needs a triangular inverse instead of ``(P^-)^{-1}``; and because the
measurement sees only the position, only the position block of ``L`` matters
(:func:`pseudo_measurement`). Fusion keeps the sums of eq. (14) in information
form and evaluates eq. (15) with the matrix inversion lemma
(:meth:`UnscentedInformationFilter.update`). Everything is batched over
vehicles (and, for the planner, over candidates and the horizon).

Conventions (:mod:`gcs.core.filters.estimate`, checked): time is integer
nanoseconds, a float stamp is refused; the state layout is named by the
estimate (``[x, y, vx, vy]`` for ``cv2d``); every method refuses arguments of
the wrong type or shape with a message naming them. A contribution remembers
the prior it was computed against, so ``update(contributions)`` needs no prior.
``second_order=True`` (the default) is the filter the daemon runs;
``second_order=False`` is eq. (12)-(13) as printed.

Fusion (eq. 14-15). Each vehicle's ``(i_v, I_v)`` depends only on its own
measurement and the shared prior (every node holds the fused estimate, the
hierarchical structure of the paper's Fig. 1); the centre sums them:
``y = y^- + sum_v i_v``, ``Y = Y^- + sum_v I_v``, ``x = Y^-1 y``. A missed
detection (occlusion, out of range) contributes nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.filters.estimate import NS_PER_S, GaussianEstimate, NotPositiveDefinite, check_stamp_ns
from gcs.core.filters.information import InformationContribution, check_estimate, fusion_inputs
from gcs.core.filters.unscented import SigmaPointParameters
from gcs.core.geometry import wrap_angle
from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel

__all__ = ["GaussianEstimate", "InformationContribution", "UnscentedInformationFilter", "pseudo_measurement",
           "checked_measurements", "NotPositiveDefinite", "NS_PER_S"]

_EYE2 = np.eye(2)
_SIGMA_DIRECTIONS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
"""Sigma-point directions in the position plane: centre, +e1, +e2, -e1, -e2."""


def _per_axis(vehicle_cov: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> bool:
    """Whether ``vehicle_cov`` holds per-axis variances (...) rather than covariances (..., 3, 3)."""
    return vehicle_cov.ndim == vehicle_xyz.ndim - 1


def pseudo_measurement(
    estimate: GaussianEstimate,
    sensor: SensorModel,
    vehicle_xyz: NDArray[np.float64],
    sigma: SigmaPointParameters,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unscented predicted measurement ``z^-`` and the position columns of ``H^p`` (eq. 12).

    The measurement depends on the target's position only, and the state lists
    position first, so with a lower Cholesky factor only the sigma points
    ``x^- +- c L e_j`` for j = 1, 2 move the position; every other sigma point
    measures ``Z^0``. Those four points are ``p^- +- c L_pp e_j`` with
    ``L_pp = chol(P_pp)`` the factor of the position block, and the velocity
    (and acceleration) columns of ``H^p = (1/2c) D^T L^-1`` are zero. The result
    is exactly that of the full-state transform, at a fraction of the cost.

    Parameters
    ----------
    estimate : GaussianEstimate
        Mean (..., n) and covariance (..., n, n) of the predicted target state.
    vehicle_xyz : ndarray, shape (..., 3)
        Vehicle positions, broadcast against the estimate's leading axes (for the
        planner: candidates x horizon against a horizon of predictions).

    Returns
    -------
    z_pred : ndarray, shape (..., m)
    h_pos : ndarray, shape (..., m, 2)
        Columns of ``H^p`` for the position (x, y); the others are zero.
    """
    n = estimate.mean.shape[-1]
    wm, _, lam = sigma.weights(n)
    c = math.sqrt(n + lam)
    # Sigma points p^- + c L_pp e_j, p^- - c L_pp e_j (j = 1, 2) after the centre: (..., 5, 2).
    points = estimate.mean[..., None, :2] + (c * _SIGMA_DIRECTIONS) @ estimate.position_cholesky.swapaxes(-1, -2)
    z_sigma = sensor.measure(points, vehicle_xyz[..., None, :])  # (..., 5, m)
    # Differences from the centre point Z^0, the azimuth wrapped: a chart that is seam-safe.
    z_centre = z_sigma[..., 0, :]
    spread = z_sigma[..., 1:, :] - z_centre[..., None, :]  # (..., 4, m)
    a = sensor.azimuth_index
    spread[..., a] = wrap_angle(spread[..., a])
    # z^- = sum_j W_m^j Z^j = Z^0 + sum_{j>=1} W_m^j (Z^j - Z^0); W_m^j is equal for j >= 1.
    z_pred = z_centre + wm[1:5] @ spread
    d = spread[..., :2, :] - spread[..., 2:, :]  # (..., 2, m): Z^j - Z^{n+j}
    h_pos = d.swapaxes(-1, -2) @ ((0.5 / c) * estimate.position_cholesky_inverse)
    return z_pred, h_pos


@dataclass(frozen=True)
class UnscentedInformationFilter:
    """Parameters of the UIF/DUIF: the motion model and the sigma-point scheme.

    The filter holds no estimate; every method takes one and returns a new one.
    """

    motion: LinearMotionModel
    sigma: SigmaPointParameters = SigmaPointParameters()
    second_order: bool = True
    """Add the linearisation's second-order variance to ``R`` (see :meth:`noise_variance`). True, the
    default, is the filter: the daemon, ``gcs replay --process`` and every bench's closed loop run it, and
    it keeps a vehicle right above the target from throwing the track off (docs/benchmarks.md). False gives
    eq. (12)-(13) as printed, for comparison with the paper (``gcs-bench estimation`` reports both)."""

    def predict(self, estimate: GaussianEstimate, stamp_ns: int) -> GaussianEstimate:
        """Predict to ``stamp_ns`` (integer nanoseconds; eq. 9, 11, 16); the same stamp returns the estimate
        itself. TypeError for a float stamp or another type of estimate, ValueError for a stamp before the
        estimate's or an estimate of another dimension than the motion model's."""
        check_estimate(estimate, "estimate")
        stamp_ns = check_stamp_ns(stamp_ns)
        if stamp_ns == estimate.stamp_ns:
            return estimate
        if stamp_ns < estimate.stamp_ns:
            raise ValueError(f"cannot predict backwards from {estimate.stamp_ns} ns to {stamp_ns} ns")
        if estimate.dim != self.motion.dim:
            raise ValueError(f"the {self.motion.name} motion model predicts {self.motion.dim}-dimensional states, "
                             f"the estimate is {estimate.layout.name} ({estimate.dim})")
        f, q = self.motion.matrices((stamp_ns - estimate.stamp_ns) / NS_PER_S)
        return GaussianEstimate.computed(f @ estimate.mean, f @ estimate.cov @ f.T + q, stamp_ns, estimate.layout)

    def contribution(
        self,
        prior: GaussianEstimate,
        sensor: SensorModel,
        z: NDArray[np.float64],
        vehicle_xyz: NDArray[np.float64],
        vehicle_cov: NDArray[np.float64] | None = None,
    ) -> InformationContribution:
        """Information contributions (eq. 12-13) of measurements ``z`` (..., m) taken from
        ``vehicle_xyz`` (..., 3), each computed on its own against the shared prior.

        ``vehicle_cov`` (..., 3, 3), when given, is the covariance of each vehicle's
        own position estimate. Its error moves the measurement like noise, to first
        order ``J_s dp_s`` with ``J_s = dH/dp_s`` (:meth:`SensorModel.vehicle_jacobian`
        at the prior mean), so ``R`` becomes ``R + J_s P_s J_s^T`` (full, not diagonal)
        in eq. (13). This treats each report's navigation error as independent of the
        others', which it is between vehicles but not over time for one vehicle (a
        slowly drifting error); the result is exact without it (None).

        ``vehicle_cov`` may instead be per-axis variances ``s^2`` (shape (...), one
        fewer axis than ``vehicle_xyz``): ``P_s = s^2 I``, a report's stated std. The
        sum then stays diagonal: the gradients of range, azimuth and elevation with
        respect to the vehicle are mutually orthogonal, so ``J_s J_s^T`` is diagonal
        and ``R`` gains ``s^2``, ``s^2 / rho_h^2`` and ``s^2 / rho^2``
        (:meth:`SensorModel.isotropic_vehicle_variance`).

        The result remembers ``prior``: :meth:`update` fuses it into that estimate without being told
        again. TypeError for a prior that is not a :class:`GaussianEstimate`, ValueError naming the
        argument for shapes that do not fit (``z`` (..., sensor.dim), ``vehicle_xyz`` (..., 3)).
        """
        z, vehicle_xyz, vehicle_cov = checked_measurements(prior, sensor, z, vehicle_xyz, vehicle_cov)
        z_pred, h_pos = pseudo_measurement(prior, sensor, vehicle_xyz, self.sigma)
        r, coupled = self._noise(prior, sensor, z_pred, vehicle_xyz, vehicle_cov)
        if coupled is None:
            ht_rinv = h_pos.swapaxes(-1, -2) / r[..., None, :]  # (H^p)^T R^-1, R diagonal: (..., 2, m)
        else:
            r_full = coupled + r[..., None] * np.eye(sensor.dim)
            ht_rinv = np.linalg.solve(r_full, h_pos).swapaxes(-1, -2)  # (H^p)^T R^-1, R symmetric: (..., 2, m)
        nu = sensor.residual(z, z_pred)
        nu += h_pos @ prior.mean[:2]  # nu + H^p x^-  (eq. 12-13)
        return InformationContribution((ht_rinv @ nu[..., None])[..., 0], ht_rinv @ h_pos, prior)

    def noise_variance(self, prior: GaussianEstimate, sensor: SensorModel, z_pred: NDArray[np.float64],
                       vehicle_xyz: NDArray[np.float64], vehicle_cov: NDArray[np.float64] | None = None
                       ) -> NDArray[np.float64]:
        """Diagonal of the ``R`` used in eq. (13), shape (..., m): the sensor's noise, plus,
        with ``second_order``, what linearising eq. (4) about the prior leaves out
        (:meth:`SensorModel.linearisation_variance`, for the relative position's
        covariance ``P_pp + P_s``)."""
        r = sensor.noise_variance(z_pred, prior.mean, vehicle_xyz)
        if not self.second_order:
            return np.broadcast_to(r, z_pred.shape)
        relative_cov = prior.cov[..., :2, :2]
        if vehicle_cov is not None:
            vehicle_cov = np.asarray(vehicle_cov, dtype=np.float64)
            if _per_axis(vehicle_cov, vehicle_xyz):
                relative_cov = relative_cov + vehicle_cov[..., None, None] * _EYE2
            else:
                relative_cov = relative_cov + vehicle_cov[..., :2, :2]
        return r + sensor.linearisation_variance(prior.mean, vehicle_xyz, relative_cov)

    def noise_covariance(self, prior: GaussianEstimate, sensor: SensorModel, z_pred: NDArray[np.float64],
                         vehicle_xyz: NDArray[np.float64], vehicle_cov: NDArray[np.float64] | None = None
                         ) -> NDArray[np.float64]:
        """The full ``R (+ J_s P_s J_s^T)`` of :meth:`contribution`, shape (..., m, m)."""
        r, coupled = self._noise(prior, sensor, z_pred, np.asarray(vehicle_xyz, dtype=np.float64), vehicle_cov)
        full = r[..., None] * np.eye(sensor.dim)
        return full if coupled is None else full + coupled

    def _noise(self, prior: GaussianEstimate, sensor: SensorModel, z_pred: NDArray[np.float64],
               vehicle_xyz: NDArray[np.float64], vehicle_cov: NDArray[np.float64] | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """The ``R`` of :meth:`contribution` as its diagonal (..., m) and, for vehicle covariances
        given as matrices, the full ``J_s P_s J_s^T`` (..., m, m) to add to it (None otherwise:
        no vehicle error, or per-axis variances, whose term is diagonal and already in)."""
        r = self.noise_variance(prior, sensor, z_pred, vehicle_xyz, vehicle_cov)
        if vehicle_cov is None:
            return r, None
        vehicle_cov = np.asarray(vehicle_cov, dtype=np.float64)
        if _per_axis(vehicle_cov, vehicle_xyz):
            return r + sensor.isotropic_vehicle_variance(prior.mean, vehicle_xyz, vehicle_cov), None
        jac = sensor.vehicle_jacobian(prior.mean[:2], vehicle_xyz)  # (..., m, 3)
        return np.broadcast_to(r, z_pred.shape), jac @ vehicle_cov @ jac.swapaxes(-1, -2)

    def update(self, prior: GaussianEstimate | InformationContribution | Sequence[InformationContribution],
               contributions: InformationContribution | Sequence[InformationContribution] | None = None
               ) -> GaussianEstimate:
        r"""Fuse contributions into their prior (eq. 14) and recover the state (eq. 15).

        ``update(contributions)`` fuses contributions made by :meth:`contribution` into the prior they
        were computed against; ``update(prior, contributions)`` says the prior too, and ValueError is raised
        when a contribution was computed against another estimate (an empty sequence returns ``prior``).
        ``contributions`` may be one :class:`InformationContribution` or a sequence of them.

        Eq. (14) sums the information: ``y = y^- + E^T i``, ``Y = Y^- + E^T A E`` with
        ``i = sum_v i_v`` and ``A = sum_v I_v`` the position-block totals and
        ``E = [I_2 0]`` the position selector. Eq. (15), ``x = Y^-1 y``, is evaluated
        with the matrix inversion lemma, exact because ``A`` has rank <= 2:

        .. math::
            P = Y^{-1} = P^- - P^- E^T A (I_2 + P_{pp} A)^{-1} E P^-, \quad
            x = Y^{-1} y = x^- + P E^T (i - A p^-)

        so neither ``Y^-`` nor ``Y`` is ever inverted.
        """
        prior, contributions = fusion_inputs(prior, contributions)
        if not contributions:
            return prior
        i_total, a_total = contributions[0].total()
        for c in contributions[1:]:
            i_more, a_more = c.total()
            i_total = i_total + i_more
            a_total = a_total + a_more
        p_cols = prior.cov[:, :2]  # P^- E^T, (n, 2)
        (m00, m01), (m10, m11) = (prior.cov[:2, :2] @ a_total).tolist()
        m00 += 1.0
        m11 += 1.0
        det = m00 * m11 - m01 * m10
        m_inv = np.array([[m11 / det, -m01 / det], [-m10 / det, m00 / det]])  # (I_2 + P_pp A)^-1
        gain = p_cols @ (a_total @ m_inv)
        cov = prior.cov - gain @ p_cols.T
        cov = 0.5 * (cov + cov.T)
        mean = prior.mean + cov[:, :2] @ (i_total - a_total @ prior.mean[:2])
        return GaussianEstimate.computed(mean, cov, prior.stamp_ns, prior.layout)


def checked_measurements(prior: GaussianEstimate, sensor: SensorModel, z: ArrayLike, vehicle_xyz: ArrayLike,
                          vehicle_cov: ArrayLike | None
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """The arguments of :meth:`UnscentedInformationFilter.contribution` as float64 arrays, shapes checked."""
    check_estimate(prior, "prior")
    if not isinstance(sensor, SensorModel):
        raise TypeError(f"sensor must be a SensorModel, got {type(sensor).__name__}")
    z_array = np.asarray(z, dtype=np.float64)
    xyz = np.asarray(vehicle_xyz, dtype=np.float64)
    if z_array.ndim == 0 or z_array.shape[-1] != sensor.dim:
        raise ValueError(f"z must have shape (..., {sensor.dim}) for a {sensor.dim}-component sensor, "
                         f"got {z_array.shape}")
    if xyz.ndim == 0 or xyz.shape[-1] != 3:
        raise ValueError(f"vehicle_xyz must have shape (..., 3) (ENU metres), got {xyz.shape}")
    if z_array.shape[:-1] != xyz.shape[:-1]:  # (equal shapes, the usual case, need no more)
        try:
            np.broadcast_shapes(z_array.shape[:-1], xyz.shape[:-1])
        except ValueError:
            raise ValueError(f"z {z_array.shape} and vehicle_xyz {xyz.shape} do not broadcast: one vehicle "
                             "position per measurement") from None
    if vehicle_cov is None:
        return z_array, xyz, None
    cov = np.asarray(vehicle_cov, dtype=np.float64)
    if cov.shape not in (xyz.shape[:-1], xyz.shape[:-1] + (3, 3)):
        raise ValueError(f"vehicle_cov must have shape {xyz.shape[:-1]} (per-axis variances) or "
                         f"{xyz.shape[:-1] + (3, 3)} (covariances), got {cov.shape}")
    return z_array, xyz, cov
