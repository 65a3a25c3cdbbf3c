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
from gcs.core.filters.uif_kernel import NO_COMPONENT, Kernel, compiled_update
from gcs.core.models.components import KNOWN_COMPONENTS
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import DetectionGroup, SensorModel

__all__ = ["RELINEARISE_SIGMA", "MAX_RELINEARISATIONS", "compile_kernel", "iterated_update", "iterated_update_many",
           "kernel_available"]

RELINEARISE_SIGMA = 3.0
"""An update that moves the position more than this many posterior sigma is linearised again about its result."""
MAX_RELINEARISATIONS = 3


def kernel_available() -> bool:
    """Whether :func:`iterated_update` runs the compiled kernel (numba is installed)."""
    return compiled_update() is not None


def compile_kernel() -> None:
    """Compile the kernel now, on a small update of its own (about 2 s, once a process; nothing without numba),
    rather than on the first update that counts: the daemon does this as it opens, so that its first fused
    step does not wait."""
    if compiled_update() is None:
        return
    truth = np.array([500.0, 0.0])
    prior = GaussianEstimate(np.array([510.0, 5.0, 0.0, 0.0]), np.diag([100.0, 100.0, 25.0, 25.0]), 0)
    sensor = SensorModel.range_bearing(10.0, 0.05, 0.05)
    xyz = np.array([[0.0, 0.0, 200.0]])
    iterated_update(UnscentedInformationFilter(constant_velocity(1.0)), prior,
                    [(sensor, sensor.measure(truth, xyz), xyz, None)])


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
    starts = np.array([0, rows[0].shape[0]], dtype=np.int64)
    mean, cov = _run_kernel(kernel, uif, prior.mean[None], prior.cov[None], starts, rows)
    return GaussianEstimate.computed(mean[0], cov[0], prior.stamp_ns, prior.layout)


def iterated_update_many(uif: UnscentedInformationFilter, means: NDArray[np.float64], covs: NDArray[np.float64],
                         sensor: SensorModel, z: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
                         compiled: bool = True) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`iterated_update` of T targets at once, each with k detections of one sensor from exactly known
    positions: priors ``means`` (T, n), ``covs`` (T, n, n), ``z`` (T, k, m), ``vehicle_xyz`` (T, k, 3).

    Returns the posterior means (T, n) and covariances (T, n, n). One kernel call updates every target
    (the numpy form, without numba or with ``compiled=False``, loops over them). ValueError for shapes
    that do not fit.
    """
    means, covs = np.asarray(means, dtype=np.float64), np.asarray(covs, dtype=np.float64)
    z, vehicle_xyz = np.asarray(z, dtype=np.float64), np.asarray(vehicle_xyz, dtype=np.float64)
    t_count, n = means.shape if means.ndim == 2 else (-1, -1)
    if covs.shape != (t_count, n, n) or z.ndim != 3 or z.shape[0] != t_count or z.shape[2] != sensor.dim \
            or vehicle_xyz.shape != z.shape[:2] + (3,):
        raise ValueError(f"need means (T, n), covs (T, n, n), z (T, k, {sensor.dim}) and vehicle_xyz (T, k, 3); "
                         f"got {means.shape}, {covs.shape}, {z.shape} and {vehicle_xyz.shape}")
    kernel = compiled_update() if compiled else None
    if kernel is None:
        out = [_numpy_iterated(uif, GaussianEstimate(m, c, 0), [(sensor, zt, xt, None)])
               for m, c, zt, xt in zip(means, covs, z, vehicle_xyz)]
        return np.stack([e.mean for e in out]), np.stack([e.cov for e in out])
    count = z.shape[0] * z.shape[1]
    z_rows = np.zeros((count, 3))
    z_rows[:, :sensor.dim] = z.reshape(count, sensor.dim)
    rows = (z_rows, np.ascontiguousarray(vehicle_xyz.reshape(count, 3)), *_sensor_rows(sensor, count),
            np.zeros(count))
    return _run_kernel(kernel, uif, means, covs, np.arange(t_count + 1, dtype=np.int64) * z.shape[1], rows)


def _run_kernel(kernel: Kernel, uif: UnscentedInformationFilter, means: NDArray[np.float64],
                covs: NDArray[np.float64], starts: NDArray[np.int64], rows: tuple[NDArray[Any], ...]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The iterated update of every target by the kernel: linearised about the priors, then again about the
    posterior for the targets it moved far (module docstring)."""
    t_count, n = means.shape
    wm, _, lam = uif.sigma.weights(n)
    c, w = math.sqrt(n + lam), float(wm[1])
    means, covs = np.ascontiguousarray(means), np.ascontiguousarray(covs)
    about_means, about_covs = means, covs
    active = np.ones(t_count, dtype=bool)
    out_means, out_covs, moved = np.empty((t_count, n)), np.empty((t_count, n, n)), np.empty(t_count)
    for _ in range(MAX_RELINEARISATIONS + 1):
        kernel(means, covs, about_means, about_covs, active, starts, *rows, uif.second_order, c, w, out_means,
               out_covs, moved)
        if np.any(moved[active] < 0.0):
            raise NotPositiveDefinite("position covariance is not positive definite")
        active = active & (moved > RELINEARISE_SIGMA**2)
        if not active.any():
            break
        about_means, about_covs = out_means.copy(), out_covs.copy()
    return out_means, out_covs


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


@lru_cache(maxsize=256)
def _sensor_rows(sensor: SensorModel, count: int) -> tuple[NDArray[Any], ...]:
    """:func:`_sensor_row` repeated for ``count`` rows (the kernel only reads them)."""
    code, variance, reference, height = _sensor_row(sensor)
    return np.tile(code, (count, 1)), np.tile(variance, (count, 1)), np.full(count, reference), np.full(count, height)


def _rows(prior: GaussianEstimate, stacked: Sequence[DetectionGroup]) -> tuple[NDArray[Any], ...] | None:
    """Every detection of every group as the kernel's rows: z, xyz, codes, variances, reference ranges, heights,
    per-axis vehicle variances (checked as ``contribution`` checks them); None when a group gives its vehicles'
    positions with full covariances."""
    if len(stacked) == 1:  # the usual step: one sensor model, exact or per-axis vehicle positions
        sensor, z, xyz, covs = stacked[0]
        z, xyz, covs = checked_measurements(prior, sensor, z, xyz, covs)
        if z.ndim == 2 and z.shape[0] == xyz.shape[0] and xyz.ndim == 2 and (covs is None or covs.ndim == 1):
            count = z.shape[0]
            code, variance, reference, height = _sensor_rows(sensor, count)
            z_rows = z if sensor.dim == 3 and z.flags.c_contiguous else np.zeros((count, 3))
            if z_rows is not z:
                z_rows[:, :sensor.dim] = z
            return (z_rows, np.ascontiguousarray(xyz), code, variance, reference, height,
                    np.zeros(count) if covs is None else np.ascontiguousarray(covs))
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
        code, variance, reference_m, height_m = _sensor_row(sensor)
        z_rows[start:stop, :sensor.dim] = z
        xyz_rows[start:stop] = xyz
        codes[start:stop], variances[start:stop] = code, variance
        references[start:stop], heights[start:stop], per_axis_rows[start:stop] = reference_m, height_m, per_axis
        start = stop
    return z_rows, xyz_rows, codes, variances, references, heights, per_axis_rows
