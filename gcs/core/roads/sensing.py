"""What a step's sensing says about point hypotheses: detections (likelihood) and looks that found nothing.

**Detections.** A step's detections come grouped by sensor model, as the
tracker stacks them (:func:`gcs.core.tracker.fuse`): ``(sensor, z (k, m),
vehicle_xyz (k, 3), vehicle_cov)``. Given the target at ``x``, the detections of
different vehicles are independent (the assumption behind the DUIF's sum of
information contributions, wang2012 eq. 14), so

.. math::
    \\ln p(Z \\mid x) = \\sum_{v} \\ln \\mathcal N\\big(z_v \\ominus h(x; p_v);\\ 0,\\ R_v(x)\\big)

with ``h`` the sensor's eq. (4) (:meth:`SensorModel.measure`), ``\\ominus`` the
azimuth-wrapping residual and ``R_v`` diagonal: the sensor's noise (zuo2021
eq. 2 growth included), plus the vehicle's own position uncertainty and the
hypothesis' spread ``sigma_x`` (a point standing for a few metres of road),
both isotropic, through :meth:`SensorModel.isotropic_vehicle_variance`
(``s^2``, ``s^2 / rho_h^2``, ``s^2 / rho^2`` for range, azimuth, elevation).

**Looks** (negative information, Koch 2007). Vehicle ``v`` that had the point
``x`` in its field and in sight (:class:`Looks`, ``sees``) detects it with
probability ``P_D``; so a vehicle that looked and found nothing multiplies a
hypothesis' likelihood by ``1 - P_D c_v(x)``, and one that detected, by
``(1 - P_D) + P_D c_v(x)`` where ``c_v(x)`` is 1 where the world says ``v`` sees
``x`` and 0 elsewhere. ``P_D < 1`` keeps a floor: the sight test the filter asks
(a table, :class:`gcs.core.world.SightTable`) is approximate, and a hypothesis
must not die of one wrong answer.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.sensor import DetectionGroup, SensorModel
from gcs.core.world.sight_table import SightTable

__all__ = ["DetectionGroup", "Looks", "per_axis_vehicle_variance", "detection_log_likelihoods",
           "detections_log_likelihood",
           "looks_log_likelihood", "table_sees"]

Sees = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.bool_]]
"""``sees(points_xy (P, 2), vehicle_xyz (V, 3)) -> (V, P)``: in the sensor's field and in sight."""

_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class Looks:
    """Every vehicle that sensed this step: positions (V, 3), which detected the target (V,), and who sees what.

    ``detection_probability`` is ``P_D`` of the module docstring.
    """

    vehicle_xyz: NDArray[np.float64]
    detected: NDArray[np.bool_]
    sees: Sees
    detection_probability: float = 0.9

    def __post_init__(self) -> None:
        if not 0.0 <= self.detection_probability < 1.0:
            raise ValueError(f"detection_probability must be in [0, 1), got {self.detection_probability!r}")
        xyz = np.asarray(self.vehicle_xyz, dtype=np.float64).reshape(-1, 3)
        detected = np.asarray(self.detected, dtype=bool).reshape(-1)
        if detected.shape != (len(xyz),):
            raise ValueError(f"detected must give one flag per vehicle ({len(xyz)}), got {detected.shape}")
        object.__setattr__(self, "vehicle_xyz", xyz)
        object.__setattr__(self, "detected", detected)


def per_axis_vehicle_variance(covs: NDArray[np.float64] | None, k: int) -> NDArray[np.float64]:
    """Per-axis variance (k,) of each vehicle's position: 0 when exact, the mean diagonal of a covariance."""
    if covs is None:
        return np.zeros(k)
    covs = np.asarray(covs, dtype=np.float64)
    if covs.ndim == 1:
        return covs
    per_axis: NDArray[np.float64] = np.trace(covs, axis1=-2, axis2=-1) / 3.0
    return per_axis


def detection_log_likelihoods(points: NDArray[np.float64], group: DetectionGroup, spread_var_m2: float = 0.0
                              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``ln N(z_j - h(x); 0, R_j(x))`` of each point (P, 2) against each detection of one group: (P, k), and the
    normalised squared residuals ``sum_m nu^2 / r`` (P, k)."""
    sensor, z, xyz, covs = group
    z = np.asarray(z, dtype=np.float64).reshape(-1, sensor.dim)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    pred = sensor.measure(points[:, None, :], xyz[None, :, :])  # (P, k, m)
    r = sensor.noise_variance(pred, points[:, None, :], xyz[None, :, :])
    extra = per_axis_vehicle_variance(covs, len(xyz)) + spread_var_m2
    if np.any(extra > 0.0):
        r = r + sensor.isotropic_vehicle_variance(points[:, None, :], xyz[None, :, :], extra[None, :])
    r = np.broadcast_to(r, pred.shape)
    nu = sensor.residual(z[None, :, :], pred)
    d2 = (nu * nu / r).sum(axis=2)
    return -0.5 * (d2 + np.log(r).sum(axis=2) + sensor.dim * _LOG_2PI), d2


def detections_log_likelihood(points: NDArray[np.float64], groups: Sequence[DetectionGroup],
                              spread_var_m2: float = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``ln p(Z | x)`` (module docstring) of every point (P, 2), summed over every detection: (P,); and the
    summed normalised squared residuals (P,), chi-square with ``sum k m`` degrees of freedom at the truth."""
    total, d2 = np.zeros(len(points)), np.zeros(len(points))
    for group in groups:
        log_lik, squares = detection_log_likelihoods(points, group, spread_var_m2)
        total += log_lik.sum(axis=1)
        d2 += squares.sum(axis=1)
    return total, d2


def looks_log_likelihood(points: NDArray[np.float64], looks: Looks | None) -> NDArray[np.float64]:
    """The looks' log-factors (module docstring) of every point (P, 2), summed over the vehicles: (P,)."""
    if looks is None or len(looks.vehicle_xyz) == 0:
        return np.zeros(len(points))
    seen = looks.sees(points, looks.vehicle_xyz)  # (V, P)
    pd = looks.detection_probability
    factor = np.where(looks.detected[:, None], np.where(seen, 1.0, 1.0 - pd), np.where(seen, 1.0 - pd, 1.0))
    log_factors: NDArray[np.float64] = np.log(factor).sum(axis=0)
    return log_factors


def table_sees(table: SightTable, max_range_m: float) -> Sees:
    """``sees`` from a :class:`SightTable` (one lookup per point, memoised) and the sensors' slant range.

    Vehicle ``v`` at altitude ``h`` and horizontal distance ``D`` along azimuth bin ``b``
    sees ``x`` when ``D / g_b(x) <= h - z_t`` and ``D^2 + (h - z_t)^2 <= r_max^2``
    (:mod:`gcs.core.world.sight_table`).
    """
    def sees(points: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.bool_]:
        slopes = table.inverse_slopes(points)  # (P, bins)
        dx = vehicle_xyz[:, None, 0] - points[None, :, 0]
        dy = vehicle_xyz[:, None, 1] - points[None, :, 1]
        rise = vehicle_xyz[:, None, 2] - table.target_height_m
        horizontal = np.hypot(dx, dy)
        inverse = slopes[np.arange(len(points))[None, :], table.bin_of(dx, dy)]
        return (horizontal * inverse <= rise) & (horizontal**2 + rise**2 <= max_range_m**2)

    return sees
