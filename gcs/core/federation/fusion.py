"""Fusing several members' estimates of one target without counting shared information twice.

Two ground stations that track the same car hold estimates whose errors are correlated: both
models share the car's unknown manoeuvres (the process noise), and neither knows by how much.
Adding their information (:func:`independent_fusion`, the DUIF's sum, wang2012 eq. (13)-(15))
is exact only when the errors are independent; with correlated errors it claims more precision
than it has. **Covariance intersection** (Julier and Uhlmann, "A non-divergent estimation
algorithm in the presence of unknown correlations", ACC 1997) fuses the information
*convexly*::

    P^-1     = w P_a^-1 + (1 - w) P_b^-1
    P^-1 x   = w P_a^-1 x_a + (1 - w) P_b^-1 x_b,      w in [0, 1]

which is consistent (never smaller than the true error covariance) for every correlation
between a and b. ``w`` is chosen to minimise ``det P`` (the volume of the fused ellipsoid,
the choice of Julier and Uhlmann), by a bounded scalar search. More than two estimates are
intersected one after another: the intersection of consistent estimates is consistent, so
the order changes the result's size a little and never its consistency.

Estimates are first brought to a common stamp with the tracks' constant-velocity model
(:func:`predict_to`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from gcs.core.models.motion import LinearMotionModel

__all__ = ["FUSION_RULES", "FusionRule", "covariance_intersection", "independent_fusion", "predict_to"]

NS_PER_S = 1_000_000_000
WEIGHT_TOLERANCE = 1e-4
"""How closely the search finds the intersection's weight ``w``."""

FusionRule = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.float64]]]


def predict_to(motion: LinearMotionModel, mean: NDArray[np.float64], cov: NDArray[np.float64], from_ns: int,
               to_ns: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """An estimate valid at ``from_ns`` brought to ``to_ns``: predicted (``x' = F x``, ``P' = F P F^T + Q``) when
    ``to_ns`` is later, taken back (``x' = F^-1 x``, ``P' = F^-1 P F^-T + Q``, the process noise of the interval
    added either way, so that the estimate stays no more certain than it was) when earlier, as a member does with
    another's newer message while it catches up on its own older steps."""
    if to_ns == from_ns:
        return mean, cov
    f, q = motion.matrices(abs(to_ns - from_ns) / NS_PER_S)
    if to_ns < from_ns:
        f = np.asarray(np.linalg.inv(f), dtype=np.float64)
    moved_mean: NDArray[np.float64] = f @ mean
    moved_cov: NDArray[np.float64] = f @ cov @ f.T + q
    return moved_mean, moved_cov


def _information(cov: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(np.linalg.inv(cov), dtype=np.float64)


def _intersect_two(mean_a: NDArray[np.float64], cov_a: NDArray[np.float64], mean_b: NDArray[np.float64],
                   cov_b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    info_a, info_b = _information(cov_a), _information(cov_b)

    def log_det_cov(w: float) -> float:
        sign, log_det = np.linalg.slogdet(w * info_a + (1.0 - w) * info_b)
        return -log_det if sign > 0 else np.inf

    w = float(minimize_scalar(log_det_cov, bounds=(0.0, 1.0), method="bounded",
                              options={"xatol": WEIGHT_TOLERANCE}).x)
    # The bounded search never evaluates the ends: an estimate that holds no more than the other is dropped whole.
    for end in (0.0, 1.0):
        if log_det_cov(end) <= log_det_cov(w):
            w = end
    info = w * info_a + (1.0 - w) * info_b
    cov = np.linalg.inv(info)
    cov = 0.5 * (cov + cov.T)
    return cov @ (w * info_a @ mean_a + (1.0 - w) * info_b @ mean_b), cov


def covariance_intersection(means: NDArray[np.float64], covs: NDArray[np.float64]
                            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The covariance intersection (module docstring) of K estimates (K, n) / (K, n, n) at one stamp."""
    if len(means) == 0:
        raise ValueError("covariance intersection needs at least one estimate")
    mean, cov = means[0], covs[0]
    for other_mean, other_cov in zip(means[1:], covs[1:]):
        mean, cov = _intersect_two(mean, cov, other_mean, other_cov)
    return mean, cov


def independent_fusion(means: NDArray[np.float64], covs: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The information sum of K estimates (K, n) / (K, n, n), exact for independent errors only (module docstring):
    ``P^-1 = sum_i P_i^-1``, ``P^-1 x = sum_i P_i^-1 x_i``."""
    if len(means) == 0:
        raise ValueError("fusion needs at least one estimate")
    infos = np.linalg.inv(covs)
    cov = np.linalg.inv(infos.sum(axis=0))
    cov = 0.5 * (cov + cov.T)
    return cov @ np.einsum("kab,kb->a", infos, means), cov


FUSION_RULES: dict[str, FusionRule] = {"ci": covariance_intersection, "independent": independent_fusion}
"""The rules a federation may fuse its members' tracks with, by name (``ci`` is the default)."""
