"""Variable-gain unscented Kalman filter (VG-UKF) for bearings with distance-dependent noise, zuo2021 eq. (5)-(14).

The target moves by the linear model ``X_{k+1} = F X_k + e_k``, ``e_k ~ N(0, Q)``
(eq. 4; here the ``cv2d`` model of :mod:`gcs.core.models.motion`, state
``[x, y, vx, vy]`` where the paper orders ``[x, vx, y, vy]``). The sensors measure
the bearings of eq. (3) with the noise variance of eq. (2), which grows with the
square of the (unknown) target range: the filter recomputes ``R~_r`` at every
update from the predicted target position ``X_{k+1|k}`` (the paper's step (4)),
so the gain of eq. (12) is an implicit function of the predicted ranges: the
"variable gain".

Steps, for a prediction ``N(x^-, P^-)`` of dimension N:

* eq. (5)-(6): sigma points ``epsilon^n = x^- +- (sqrt((N + lambda) P^-))_n`` with the
  scaled weights of :class:`~gcs.core.filters.unscented.SigmaPointParameters`.
  (Eq. (6) as printed gives the non-central points the weight
  ``lambda / (2 (N + lambda))``; it is ``1 / (2 (N + lambda))``, or the weights do
  not sum to one.)
* eq. (7), (9): for the linear motion model the unscented prediction is exactly
  ``F x`` and ``F P F^T + Q``, which :meth:`VariableGainUKF.predict` computes. The
  update draws its sigma points from that prediction (so ``Q`` spreads them too),
  where the paper reuses the propagated posterior points.
* eq. (8): ``z^- = sum_n w^n h(epsilon^n)``, with every azimuth taken relative to
  the centre point's and wrapped (seam-safe).
* eq. (10)-(11): ``P^zz = sum_n w_c^n (Z^n - z^-)(Z^n - z^-)^T + R~_r`` and
  ``P^xz = sum_n w_c^n (epsilon^n - x^-)(Z^n - z^-)^T``. (Eq. (11) as printed also
  adds ``R~_r`` to the cross-covariance; that is a misprint: the shapes differ.)
* eq. (12)-(14): ``K = P^xz (P^zz)^-1``, ``x = x^- + K (z - z^-)`` (azimuths
  wrapped), ``P = P^- - K P^zz K^T``. (Eq. (14) as printed has ``+``.)

``R~_r`` uses the predicted *mean* position, as the paper says, not an average over
the sigma points.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.filters.aoa_init import AoaScan
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.filters.unscented import SigmaPointParameters
from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel

__all__ = ["ScanFilter", "VariableGainUKF", "kalman_correction"]


def kalman_correction(
    prior: GaussianEstimate,
    cross_cov: NDArray[np.float64],
    innovation_cov: NDArray[np.float64],
    innovation: NDArray[np.float64],
) -> GaussianEstimate:
    """``K = P^xz (P^zz)^-1``, ``x = x^- + K nu``, ``P = P^- - K P^zz K^T`` (eq. 12-14), symmetrised."""
    gain = np.linalg.solve(innovation_cov, cross_cov.T).T  # eq. (12)
    cov = prior.cov - gain @ innovation_cov @ gain.T  # eq. (14), sign corrected
    return GaussianEstimate(prior.mean + gain @ innovation, 0.5 * (cov + cov.T), prior.stamp_ns)  # eq. (13)


@dataclass(frozen=True)
class ScanFilter:
    """A filter of bearing scans: linear prediction, and an update from one scan of M sensors.

    Holds parameters only; :meth:`predict` and :meth:`update` take an estimate and
    return a new one. Subclasses implement :meth:`correct`.
    """

    motion: LinearMotionModel

    def predict(self, estimate: GaussianEstimate, stamp_ns: int) -> GaussianEstimate:
        """Predict to ``stamp_ns`` (eq. 4, 7, 9): ``F x``, ``F P F^T + Q``, exact for the linear model."""
        return UnscentedInformationFilter(self.motion).predict(estimate, stamp_ns)

    def update(
        self,
        estimate: GaussianEstimate,
        sensors: Sequence[SensorModel],
        z: NDArray[np.float64] | Sequence[ArrayLike],
        sensor_xyz: ArrayLike,
    ) -> GaussianEstimate:
        """Fuse one scan of M sensors taken at the estimate's time.

        Parameters
        ----------
        estimate : GaussianEstimate
            The prediction ``X_{k+1|k}``, ``P_{k+1|k}`` (mean (n,), covariance (n, n)).
        sensors : sequence of SensorModel, length M
            Their ``std`` is ``sigma_i0`` of eq. (2); ``distance_dependent`` switches eq. (2) on.
        z : array_like
            The measurements: (M,) bearings for azimuth-only sensors (see :meth:`AoaScan.of`).
        sensor_xyz : array_like, shape (M, 3)
            Sensor positions at the time of the scan.
        """
        return self.correct(estimate, AoaScan.of(sensors, z, sensor_xyz))

    def correct(self, estimate: GaussianEstimate, scan: AoaScan) -> GaussianEstimate:
        """The measurement update proper."""
        raise NotImplementedError


@dataclass(frozen=True)
class VariableGainUKF(ScanFilter):
    """Parameters of the VG-UKF: the motion model and the sigma-point scheme."""

    sigma: SigmaPointParameters = SigmaPointParameters()

    def correct(self, estimate: GaussianEstimate, scan: AoaScan) -> GaussianEstimate:
        """Eq. (5)-(6), (8), (10)-(14) for the scan, ``R~_r`` from eq. (2) at the predicted position."""
        n = estimate.mean.shape[-1]
        wm, wc, _ = self.sigma.weights(n)
        points = self.sigma.points(estimate.mean, estimate.cov)  # eq. (5), (2n+1, n)
        z_points = scan.measure(points)  # h(epsilon^n), (2n+1, m)
        spread = scan.residual(z_points[0], z_points)  # Z^n - Z^0, azimuths wrapped
        z_pred = z_points[0] + wm @ spread  # eq. (8)
        dz = spread - wm @ spread  # Z^n - z^-
        dx = points - estimate.mean
        r_tilde = scan.variance(estimate.mean[:2])  # eq. (2) at the predicted position: R~_r
        p_zz = (dz.T * wc) @ dz + np.diag(r_tilde)  # eq. (10)
        p_xz = (dx.T * wc) @ dz  # eq. (11)
        return kalman_correction(estimate, p_xz, p_zz, scan.residual(z_pred))
