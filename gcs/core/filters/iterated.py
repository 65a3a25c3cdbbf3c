"""The DUIF update the tracking loop runs: eq. (12)-(15), linearised again about its result when it moved far.

Eq. (12) linearises the measurement about the prior. When the prior is wide and wrong
(the target was hidden for a while and turned), a detection that fixes the position to
a few metres lands far from that point, and one update leaves the estimate short of it.
So when the posterior mean lies more than :data:`RELINEARISE_SIGMA` posterior standard
deviations (position, Mahalanobis) from the point the measurement was linearised about,
the contributions are computed again about the posterior (its mean and covariance, for
the sigma points and the second-order ``R``) and fused into the same prior: the iterated
filter's Gauss-Newton step (Bell and Cathey 1993), at most :data:`MAX_RELINEARISATIONS`
times. An update that stays near the prior, the usual case, is eq. (12)-(15) unchanged.

Two implementations give the same numbers to rounding: the numpy form
(:meth:`~gcs.core.filters.uif.UnscentedInformationFilter.contribution` and
:meth:`~gcs.core.filters.uif.UnscentedInformationFilter.update`), and the compiled
kernel of :mod:`gcs.core.filters.uif_kernel`, used when numba is installed. The numpy
form spends about a microsecond of call overhead on every line of the algorithm; the
kernel runs a whole linearisation, every vehicle's contribution and their fusion, in
one call. Detections whose vehicle position comes with a full covariance (which makes
``R`` full) take the numpy form.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import GaussianEstimate, NotPositiveDefinite
from gcs.core.filters.information import check_estimate
from gcs.core.filters.uif import UnscentedInformationFilter, checked_measurements
from gcs.core.filters.uif_kernel import NO_COMPONENT, compiled_update
from gcs.core.models.components import KNOWN_COMPONENTS
from gcs.core.models.sensor import DetectionGroup, SensorModel

__all__ = ["RELINEARISE_SIGMA", "MAX_RELINEARISATIONS", "iterated_update", "kernel_available"]

RELINEARISE_SIGMA = 3.0
"""An update that moves the position more than this many posterior sigma is linearised again about its result."""
MAX_RELINEARISATIONS = 3


def kernel_available() -> bool:
    """Whether :func:`iterated_update` runs the compiled kernel (numba is installed)."""
    return compiled_update() is not None


def iterated_update(uif: UnscentedInformationFilter, prior: GaussianEstimate,
                    stacked: Sequence[DetectionGroup], compiled: bool = True) -> GaussianEstimate:
    """The DUIF update of ``prior`` with every group of ``stacked`` (module docstring).

    ``compiled=False`` runs the numpy form even when the kernel is available. TypeError or
    ValueError for arguments of the wrong type or shape, as
    :meth:`~gcs.core.filters.uif.UnscentedInformationFilter.contribution`;
    :class:`~gcs.core.filters.estimate.NotPositiveDefinite` when a covariance loses definiteness.
    """
    kernel = compiled_update() if compiled else None
    if kernel is None or not stacked or not isinstance(prior, GaussianEstimate) or prior.mean.ndim != 1:
        return _numpy_iterated(uif, prior, stacked)
    check_estimate(prior, "prior")
    rows = _rows(prior, stacked)
    if rows is None:
        return _numpy_iterated(uif, prior, stacked)
    n = prior.dim
    wm, _, lam = uif.sigma.weights(n)
    c, w = math.sqrt(n + lam), float(wm[1])
    mean, cov = np.ascontiguousarray(prior.mean), np.ascontiguousarray(prior.cov)
    about_mean, about_cov = mean, cov
    for _ in range(MAX_RELINEARISATIONS + 1):
        posterior_mean, posterior_cov = np.empty(n), np.empty((n, n))
        moved2 = kernel(mean, cov, about_mean, about_cov, *rows, uif.second_order, c, w, posterior_mean, posterior_cov)
        if moved2 < 0.0:
            raise NotPositiveDefinite("position covariance is not positive definite")
        if moved2 <= RELINEARISE_SIGMA**2:
            break
        about_mean, about_cov = posterior_mean, posterior_cov
    return GaussianEstimate.computed(posterior_mean, posterior_cov, prior.stamp_ns, prior.layout)


def _numpy_iterated(uif: UnscentedInformationFilter, prior: GaussianEstimate,
                    stacked: Sequence[DetectionGroup]) -> GaussianEstimate:
    about = prior
    posterior = prior
    for _ in range(MAX_RELINEARISATIONS + 1):
        contributions = [uif.contribution(about, sensor, z, xyz, covs) for sensor, z, xyz, covs in stacked]
        if about is not prior:
            contributions = [c.linearised_about(about, prior) for c in contributions]
        posterior = uif.update(prior, contributions)
        moved = posterior.mean[:2] - about.mean[:2]
        if moved @ np.linalg.solve(posterior.cov[:2, :2], moved) <= RELINEARISE_SIGMA**2:
            break
        about = posterior
    return posterior


@lru_cache(maxsize=64)
def _sensor_row(sensor: SensorModel) -> tuple[NDArray[np.int64], NDArray[np.float64], float, float]:
    """A sensor as the kernel reads it: component codes (3,), variances (3,), the reference range of
    distance-dependent noise (0 for constant noise) and the target's height."""
    codes = np.full(3, NO_COMPONENT, dtype=np.int64)
    variances = np.zeros(3)
    for k, (component, std) in enumerate(zip(sensor.components, sensor.std)):
        codes[k] = KNOWN_COMPONENTS.index(component)
        variances[k] = float(std) ** 2
    reference = float(sensor.reference_range_m) if sensor.distance_dependent else 0.0
    return codes, variances, reference, float(sensor.target_height_m)


def _rows(prior: GaussianEstimate, stacked: Sequence[DetectionGroup]) -> tuple[NDArray[Any], ...] | None:
    """Every detection of every group as the kernel's rows: z, xyz, codes, variances, reference ranges, heights,
    per-axis vehicle variances (checked as ``contribution`` checks them); None when a group gives its vehicles'
    positions with full covariances."""
    parts = []
    for sensor, z, xyz, covs in stacked:
        z, xyz, covs = checked_measurements(prior, sensor, z, xyz, covs)
        if covs is not None and covs.ndim == xyz.ndim + 1:  # (k, 3, 3) covariances: R is full
            return None
        lead = np.broadcast_shapes(z.shape[:-1], xyz.shape[:-1])
        count = math.prod(lead)
        per_axis = np.zeros(count) if covs is None else np.broadcast_to(covs, lead).reshape(count)
        parts.append((sensor, np.broadcast_to(z, lead + z.shape[-1:]).reshape(count, sensor.dim),
                      np.broadcast_to(xyz, lead + (3,)).reshape(count, 3), per_axis))
    total = sum(p[1].shape[0] for p in parts)
    z_rows, xyz_rows = np.zeros((total, 3)), np.empty((total, 3))
    codes, variances = np.empty((total, 3), dtype=np.int64), np.empty((total, 3))
    references, heights, per_axis_rows = np.empty(total), np.empty(total), np.empty(total)
    start = 0
    for sensor, z, xyz, per_axis in parts:
        stop = start + z.shape[0]
        code, variance, reference, height = _sensor_row(sensor)
        z_rows[start:stop, :sensor.dim] = z
        xyz_rows[start:stop] = xyz
        codes[start:stop], variances[start:stop] = code, variance
        references[start:stop], heights[start:stop], per_axis_rows[start:stop] = reference, height, per_axis
        start = stop
    return z_rows, xyz_rows, codes, variances, references, heights, per_axis_rows
