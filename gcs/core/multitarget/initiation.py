"""New tracks from unassociated range-bearing detections: the measurement inverted to a ground position.

For a vehicle at ``p_s = (x_s, y_s, z_s)`` and a target on the plane at height
``z_t`` (``dz = z_t - z_s``), a detection of range ``rho``, azimuth ``phi`` and,
when measured, elevation ``theta`` (wang2012 eq. 4) places the target at

.. math::
    p = (x_s, y_s) + \\rho_h u, \\quad u = (\\cos\\varphi, \\sin\\varphi), \\quad
    \\rho_h = \\rho\\cos\\theta \\;\\text{(with elevation)}, \\;
    \\rho_h = \\sqrt{\\rho^2 - dz^2} \\;\\text{(without)}

with the first-order covariance ``G_z R G_z^T + G_s P_s G_s^T`` (``G_z = dp/dz``,
``G_s = dp/dp_s``, ``v = (-sin phi, cos phi)``):

.. math::
    \\frac{\\partial p}{\\partial \\varphi} = \\rho_h v, \\quad
    \\frac{\\partial p}{\\partial \\rho} = \\cos\\theta\\, u \\text{ or } \\frac{\\rho}{\\rho_h} u, \\quad
    \\frac{\\partial p}{\\partial \\theta} = -\\rho\\sin\\theta\\, u, \\quad
    G_s = [\\, I_2 \\mid 0 \\,] \\text{ or } [\\, I_2 \\mid \\tfrac{dz}{\\rho_h} u \\,]

The velocity is unknown: zero mean, a stated standard deviation per axis (the
one-point initiation; Blackman & Popoli 1999, track initiation).

Bearing-only detections (azimuth, with or without elevation) do not start
tracks. One azimuth is a ray: the range along it is unobserved, and a prior
wide enough to cover it is far from Gaussian after the update. Elevation over
a known ground plane does fix a range, ``rho_h = -dz / tan(theta)``, but its
error grows as ``rho_h^2 / |dz|`` times the elevation noise, which at the low
grazing angles of a surveillance UAV is hundreds of metres. Triangulating
bearings from several vehicles needs an association across vehicles of
detections that carry no identity, whose ghost intersections grow as the square
of the number of targets; that is a separate problem.

Several vehicles seeing the same new target in one scan would start one track
each; so candidates of one scan whose positions agree (the chi-square gate on
``p_i - p_k`` with covariance ``P_i + P_k``, 2 degrees of freedom) and come from
different vehicles are fused (information sum) into one.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.sensor import AZIMUTH, ELEVATION, RANGE, SensorModel

__all__ = ["starts_tracks", "ground_positions", "merge_candidates", "initial_states"]

_MIN_HORIZONTAL_M = 1e-3


def starts_tracks(sensor: SensorModel) -> bool:
    """Whether a detection of this sensor can start a track alone: it must measure range and azimuth."""
    return RANGE in sensor.components and AZIMUTH in sensor.components


def ground_positions(sensor: SensorModel, z: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
                     vehicle_cov: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ground positions (k, 2) and their covariances (k, 2, 2) of k range-bearing detections.

    Parameters
    ----------
    z : ndarray, shape (k, m)
    vehicle_xyz : ndarray, shape (k, 3)
    vehicle_cov : ndarray, shape (k, 3, 3)
    """
    if not starts_tracks(sensor):
        raise ValueError(f"a {sensor.components} sensor cannot start tracks: it needs range and azimuth")
    comps = sensor.components
    rho = z[:, comps.index(RANGE)]
    phi = z[:, comps.index(AZIMUTH)]
    u = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    v = np.stack([-np.sin(phi), np.cos(phi)], axis=-1)
    dz = sensor.target_height_m - vehicle_xyz[:, 2]
    g_z = np.zeros(z.shape[:1] + (2, sensor.dim))
    g_s = np.zeros(z.shape[:1] + (2, 3))
    g_s[:, 0, 0] = g_s[:, 1, 1] = 1.0
    if ELEVATION in comps:
        theta = z[:, comps.index(ELEVATION)]
        rho_h = np.maximum(rho * np.cos(theta), _MIN_HORIZONTAL_M)
        g_z[:, :, comps.index(RANGE)] = np.cos(theta)[:, None] * u
        g_z[:, :, comps.index(ELEVATION)] = (-rho * np.sin(theta))[:, None] * u
    else:
        rho_h = np.sqrt(np.maximum(rho * rho - dz * dz, _MIN_HORIZONTAL_M**2))
        g_z[:, :, comps.index(RANGE)] = (rho / rho_h)[:, None] * u
        g_s[:, :, 2] = (dz / rho_h)[:, None] * u
    g_z[:, :, comps.index(AZIMUTH)] = rho_h[:, None] * v
    mean = vehicle_xyz[:, :2] + rho_h[:, None] * u
    r = np.broadcast_to(sensor.noise_variance(z, mean, vehicle_xyz), z.shape)
    cov = (g_z * r[:, None, :]) @ g_z.swapaxes(-1, -2) + g_s @ vehicle_cov @ g_s.swapaxes(-1, -2)
    return mean, 0.5 * (cov + cov.swapaxes(-1, -2))


def merge_candidates(mean: NDArray[np.float64], cov: NDArray[np.float64], vehicle: NDArray[np.int64],
                     threshold: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Fuse candidates of one scan that agree and come from different vehicles; (k', 2), (k', 2, 2).

    Greedy in input order: a candidate joins the first earlier group, holding no
    candidate of its vehicle, whose fused position is within ``threshold``
    (squared Mahalanobis distance of the difference); groups are fused as
    information sums ``P^-1 = sum_i P_i^-1``, ``P^-1 p = sum_i P_i^-1 p_i``.
    """
    groups: list[tuple[NDArray[np.float64], NDArray[np.float64], set[int]]] = []
    for p_i, c_i, v_i in zip(mean, cov, vehicle.tolist()):
        y_i = np.linalg.inv(c_i)
        for index, (p_g, c_g, seen) in enumerate(groups):
            diff = p_i - p_g
            if v_i not in seen and diff @ np.linalg.solve(c_i + c_g, diff) <= threshold:
                y_g = np.linalg.inv(c_g)
                fused = np.linalg.inv(y_g + y_i)
                groups[index] = (fused @ (y_g @ p_g + y_i @ p_i), fused, seen | {v_i})
                break
        else:
            groups.append((p_i, c_i, {v_i}))
    if not groups:
        return np.zeros((0, 2)), np.zeros((0, 2, 2))
    return np.array([g[0] for g in groups]), np.array([g[1] for g in groups])


def initial_states(position: NDArray[np.float64], position_cov: NDArray[np.float64],
                   velocity_std_mps: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``[x, y, 0, 0]`` (k, 4) and block-diagonal covariances (k, 4, 4): the position's, ``s^2 I_2`` for velocity."""
    k = position.shape[0]
    mean = np.zeros((k, 4))
    mean[:, :2] = position
    cov = np.zeros((k, 4, 4))
    cov[:, :2, :2] = position_cov
    cov[:, 2, 2] = cov[:, 3, 3] = velocity_std_mps**2
    return mean, cov
