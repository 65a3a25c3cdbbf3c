"""Extended Kalman filter baselines for bearing-only tracking (zuo2021 section 5, Fig. 2).

The paper compares its ML-VUKF with ML-MEKF (an ML-initialised modified polar EKF,
ref. [5]) and LS-ISFEKF (a least-squares-initialised fading-memory EKF, ref. [16]).
In their spirit, and on the same interface as
:class:`~gcs.core.filters.vgukf.VariableGainUKF`:

* **ML-EKF**: :func:`~gcs.core.filters.aoa_init.ml_initialise` then
  :class:`BearingEKF`;
* **LS-EKF**: :func:`~gcs.core.filters.aoa_init.pseudo_linear_initialise` then the
  same :class:`BearingEKF`.

:class:`BearingEKF` is the Cartesian EKF with the *constant* noise ``sigma_i0^2`` of
each sensor (it ignores eq. (2)), unless ``distance_dependent_noise`` is set, when it
evaluates eq. (2) at the predicted position like the VG-UKF (an ablation). Update,
with ``H`` the Jacobian of eq. (3) at the prediction ``x^-``:

.. math::
    S = H P^- H^T + R, \\quad K = P^- H^T S^{-1}, \\quad
    x = x^- + K (z - h(x^-)), \\quad P = P^- - K S K^T

the bearing residual wrapped to (-pi, pi].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gcs.core.filters.aoa_init import AoaScan
from gcs.core.filters.uif import GaussianEstimate
from gcs.core.filters.vgukf import ScanFilter, kalman_correction

__all__ = ["BearingEKF"]


@dataclass(frozen=True)
class BearingEKF(ScanFilter):
    """Parameters of the bearing EKF: the motion model and whether eq. (2) is used.

    ``predict`` and ``update`` (from :class:`~gcs.core.filters.vgukf.ScanFilter`) return
    new estimates, as for the VG-UKF.
    """

    distance_dependent_noise: bool = False

    def correct(self, estimate: GaussianEstimate, scan: AoaScan) -> GaussianEstimate:
        """The EKF update of the module docstring for one scan."""
        mean = estimate.mean
        h = scan.jacobian(mean, mean.shape[-1])  # (m, n)
        r = scan.variance(mean[:2], self.distance_dependent_noise)
        cross = estimate.cov @ h.T  # P^- H^T
        return kalman_correction(estimate, cross, h @ cross + np.diag(r), scan.residual(scan.measure(mean)))
