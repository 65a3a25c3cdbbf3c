"""feng2019's distributed fusion (DF): local INS/GPS and INS/map filters and a fusion centre.

The paper compares centralised fusion (every observation in one switching
filter, :func:`gcs.core.navigation.skf.nav_update`) with distributed fusion, for
which it gives no equations. We use Carlson's federated filter (1990) in its
no-reset mode, the classic decentralised INS-aided architecture:

* local filter G: INS prediction (eq. 1) and the GNSS observations (GPS eq. 4-5,
  velocity, heading); a single-mode EKF;
* local filter M: INS prediction and the map observations of the candidate route
  segments (eq. 2-3); the switching filter over segments, no GNSS;
* each local filter shares the INS information through the factors
  ``beta_G + beta_M = 1``: its process noise (and initial covariance) is scaled by
  ``1 / beta``, so that the common INS information is not counted twice;
* the fusion centre combines the two collapsed local estimates as independent:

.. math::
    P_f^{-1} = P_G^{-1} + P_M^{-1}, \\qquad
    x_f = P_f \\big(P_G^{-1} x_G + P_M^{-1} x_M\\big)

(heading of ``x_M`` taken relative to ``x_G``'s and wrapped). Without reset the
local filters never see the fused result, which keeps them independent of the
centre and of each other but costs accuracy against CF, as the paper's Table 1
shows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.navigation.model import THETA
from gcs.core.navigation.route import RouteSegment
from gcs.core.navigation.skf import NavEstimate, NavMeasurement, NavParams, common_observations, switch_update

__all__ = ["FederatedEstimate", "federated_start", "federated_update", "fuse_estimates"]


def fuse_estimates(mean_a: NDArray[np.float64], cov_a: NDArray[np.float64], mean_b: NDArray[np.float64],
                   cov_b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The fusion centre's equation (module docstring) for two independent estimates (6,), (6, 6)."""
    b = mean_b.copy()
    b[THETA] = mean_a[THETA] + wrap_angle(mean_b[THETA] - mean_a[THETA])
    info_a, info_b = np.linalg.inv(cov_a), np.linalg.inv(cov_b)
    cov = np.linalg.inv(info_a + info_b)
    mean = cov @ (info_a @ mean_a + info_b @ b)
    mean[THETA] = wrap_angle(mean[THETA])
    return mean, 0.5 * (cov + cov.T)


@dataclass(frozen=True)
class FederatedEstimate:
    """The local estimates (``gps``: INS/GPS, ``map``: INS/map) and their fusion ``mean`` (6,), ``cov`` (6, 6)."""

    stamp_ns: int
    gps: NavEstimate
    map: NavEstimate
    beta_gps: float
    mean: NDArray[np.float64] = field(init=False)
    cov: NDArray[np.float64] = field(init=False)

    def __post_init__(self) -> None:
        if not 0.0 < self.beta_gps < 1.0:
            raise ValueError(f"beta_gps must be in (0, 1), got {self.beta_gps}")
        mean, cov = fuse_estimates(self.gps.mean, self.gps.cov, self.map.mean, self.map.cov)
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "cov", cov)


def federated_start(prior: NavEstimate, beta_gps: float = 0.5) -> FederatedEstimate:
    """Both local filters from the same prior (e.g. :func:`~gcs.core.navigation.skf.initial`), its
    covariance scaled by ``1 / beta`` each."""

    def scaled(beta: float) -> NavEstimate:
        return replace(prior, mixture=replace(prior.mixture, covs=prior.mixture.covs / beta))

    return FederatedEstimate(prior.stamp_ns, scaled(beta_gps), scaled(1.0 - beta_gps), beta_gps)


def federated_update(params: NavParams, estimate: FederatedEstimate, measurement: NavMeasurement,
                     route: Sequence[RouteSegment] = ()) -> FederatedEstimate:
    """One DF step: each local filter on its own observations, then the fusion centre."""
    beta = estimate.beta_gps
    gps = switch_update(params, estimate.gps, measurement, (), common_observations(params, measurement), 1.0 / beta)
    local_map = switch_update(params, estimate.map, measurement, route, (), 1.0 / (1.0 - beta))
    return FederatedEstimate(measurement.stamp_ns, gps, local_map, beta)
