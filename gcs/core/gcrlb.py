"""Generalised Cramer-Rao lower bound (GCRLB) for sensors with distance-dependent noise, zuo2021 section 3.

A bearing ``theta_i = atan2(y_t - y_i, x_t - x_i) + n_i`` (eq. 1) has the noise
variance of eq. (2), ``sigma_i^2 = sigma_i0^2 r_i^2 / r_0^2`` beyond the reference
range ``r_0`` and ``sigma_i0^2`` inside it. Because the variance depends on the
target position ``p``, the Fisher information of ``z ~ N(h(p), R(p))`` has two
terms (van Trees 2001; eq. 15):

.. math::
    J_{ab} = \\partial_a h^T R^{-1} \\partial_b h
           + \\tfrac12 \\operatorname{tr}\\big(R^{-1} \\partial_a R\\, R^{-1} \\partial_b R\\big)
           = J_1 + J_2                                                   \\qquad (15)

For one planar bearing beyond ``r_0``, with ``beta_i = sigma_i0^2 / r_0^2``,
``u_i = (-sin theta_i, cos theta_i)`` (across the line of sight) and
``v_i = (cos theta_i, sin theta_i)`` (along it):

.. math::
    J_1 = \\sum_i \\frac{u_i u_i^T}{\\beta_i r_i^4}, \\qquad
    J_2 = \\sum_i \\frac{2}{r_i^2} v_i v_i^T                             \\qquad (16, 17)

Inside ``r_0`` the variance is constant, ``J_2`` vanishes and ``J_1 = u u^T /
(sigma_0^2 r^2)``. The implementation (:func:`fisher_information`) is the general
form for any :class:`~gcs.core.models.sensor.SensorModel` with ``m`` components
all scaled by ``s(rho) = max(rho / rho_0, 1)^2`` (eq. 2 for each component, ``rho``
the 3-D range): ``J_1 = H^T R^-1 H`` and ``J_2 = (m / 2) grad log s grad log s^T``,
which is eq. (16)-(17) for a planar azimuth-only sensor.

The GCRLB is ``J^-1`` (eq. 23); its trace is the A-optimality criterion
``f = 4 A / (A^2 - B_1^2 - B_2^2)`` of eq. (24), with ``a_i = 2 / r_i^2``,
``b_i = 1 / (beta_i r_i^4)``, ``c_i = a_i + b_i``, ``d_i = a_i - b_i``,
``A = sum c_i``, ``B_1 + j B_2 = sum d_i exp(2 j theta_i)`` (eq. 19-22).

Section 3 of the paper, checked (``tests/unit/test_gcrlb.py``):

* Eq. (25) as printed drops the angle-free cross terms: expanding eq. (24) gives
  ``A^2 - B_1^2 - B_2^2 = 4 [sum_i a_i b_i + sum_{i<j} (a_i b_j + a_j b_i)
  + sum_{i<j} d_i d_j sin^2 phi_ij]``; :func:`trace_from_angles` is the corrected
  form. The missing terms do not depend on the angles, so the angle results hold.
* Eq. (27) should read ``d f_1 / d phi_12 = d_1 d_2 sin 2 phi_12``; for two
  sensors the optimum ``phi_12 = +-pi/2`` is right (for any ranges, since
  ``d_1 d_2 > 0`` whenever both ranges are on the same side of
  ``r_0 / (sigma_0 sqrt 2)``, about 61 km for sigma_0 = 1 deg, r_0 = 1500 m).
* Section 3.2 (b), "``phi_ij = +-pi/2`` for M >= 3", is wrong (three bearing lines
  cannot be pairwise perpendicular). With equal ranges the trace is minimal
  exactly when ``sum_i exp(2 j theta_i) = 0`` (``B_1 = B_2 = 0``), e.g. the
  sensors ``pi / M`` apart as section 3.3 states (eq. 31); for M = 3 this is the
  only optimum (up to rotation and ``theta -> theta + pi``), for M >= 4 it is one
  of many.
* The optimal value printed after eq. (31), ``4 beta r_max^4 / (M (2 beta r_max^2
  + 1))``, holds with ``r_min`` in place of ``r_max`` (:func:`optimal_trace`).
* Eq. (29) and the conclusion "closer is better, ``r_i = r_min``" hold beyond
  ``r_0``: every ``J_i`` grows in the Loewner order as ``r_i`` shrinks. At ``r_0``
  the bound jumps up by the factor ``1 + 2 sigma_0^2`` (1.0006 for 1 deg) when the
  range term ``J_2`` switches off, so for ``r_min`` just inside ``r_0`` the infimum
  is approached from just outside ``r_0``; negligible, but the paper does not say.
* Section 3.3's sector cases (32)-(33) say the ``pi / M`` spacing is reachable for
  any sector wider than ``pi / M``; it needs ``(M - 1) pi / M`` (``pi / 2`` for two
  sensors, ``2 pi / 3`` for three). Conclusion (1), "the optimal angle is
  ``pi / 2``", holds for two sensors only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.motion import LinearMotionModel
from gcs.core.models.sensor import SensorModel
from gcs.core.pcrlb import information_recursion

__all__ = [
    "log_variance_gradient",
    "fisher_information",
    "gcrlb",
    "gcrlb_trace",
    "planar_fisher_information",
    "trace_from_angles",
    "optimal_trace",
    "tracking_gcrlb",
]


def log_variance_gradient(
    sensor: SensorModel, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Gradient of ``log s`` with respect to the target's (x, y), eq. (2).

    Every component's variance is ``sigma_k0^2 s`` with ``s = max(rho / rho_0, 1)^2``,
    so ``grad log sigma_k^2 = grad log s = 2 (dx, dy) / rho^2`` beyond ``rho_0`` and 0
    inside it (and for constant-noise sensors); ``(dx, dy)`` is target minus vehicle.

    Returns
    -------
    ndarray, shape (..., 2)
    """
    target_xy = np.asarray(target_xy, dtype=np.float64)
    vehicle_xyz = np.asarray(vehicle_xyz, dtype=np.float64)
    d = target_xy[..., :2] - vehicle_xyz[..., :2]
    rho = sensor.distance(target_xy, vehicle_xyz)
    if not sensor.distance_dependent:
        return np.zeros(np.broadcast_shapes(d.shape, rho.shape + (2,)))
    outside = rho > sensor.reference_range_m
    return np.where(outside[..., None], 2.0 * d / (rho * rho)[..., None], 0.0)


def fisher_information(
    sensors: Sequence[SensorModel], target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Fisher information ``J = J_1 + J_2`` about the target's (x, y), eq. (15)-(17).

    Parameters
    ----------
    sensors : sequence of SensorModel, length M
    target_xy : ndarray, shape (..., >=2)
        True target position (only x, y are used).
    vehicle_xyz : ndarray, shape (..., M, 3)
        Sensor positions, broadcast against ``target_xy``'s leading axes (the
        planner passes a population of candidate positions).

    Returns
    -------
    ndarray, shape (..., 2, 2)
    """
    target_xy = np.asarray(target_xy, dtype=np.float64)
    vehicle_xyz = np.asarray(vehicle_xyz, dtype=np.float64)
    if vehicle_xyz.shape[-2] != len(sensors):
        raise ValueError(f"{len(sensors)} sensors for {vehicle_xyz.shape[-2]} positions")
    info: NDArray[np.float64] | float = 0.0
    for i, sensor in enumerate(sensors):
        xyz = vehicle_xyz[..., i, :]
        xx, xy, yy = sensor.fisher_information_xy(target_xy, xyz)  # J_1 = H^T R^-1 H, eq. (16)
        j1 = np.stack([np.stack([xx, xy], -1), np.stack([xy, yy], -1)], -2)
        g = log_variance_gradient(sensor, target_xy, xyz)
        j2 = 0.5 * sensor.dim * g[..., :, None] * g[..., None, :]  # eq. (17): (m/2) grad log s grad log s^T
        info = info + j1 + j2
    return np.asarray(info)


def gcrlb(
    sensors: Sequence[SensorModel], target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The bound ``J^-1`` on the position error covariance (eq. 23), shape (..., 2, 2)."""
    return np.linalg.inv(fisher_information(sensors, target_xy, vehicle_xyz)).astype(np.float64, copy=False)


def gcrlb_trace(
    sensors: Sequence[SensorModel], target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``tr(J^-1) = (J_11 + J_22) / det J`` (eq. 24), shape (...): the planner's objective (eq. 34)."""
    info = fisher_information(sensors, target_xy, vehicle_xyz)
    det = info[..., 0, 0] * info[..., 1, 1] - info[..., 0, 1] * info[..., 1, 0]
    return (info[..., 0, 0] + info[..., 1, 1]) / det


def _abcd(ranges: NDArray[np.float64], beta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """``a_i = 2 / r_i^2``, ``b_i = 1 / (beta_i r_i^4)``, ``c_i``, ``d_i`` (after eq. 21), ranges beyond r_0."""
    r2 = np.asarray(ranges, dtype=np.float64) ** 2
    a = 2.0 / r2
    b = 1.0 / (np.asarray(beta, dtype=np.float64) * r2 * r2)
    return a, b, a + b, a - b


def planar_fisher_information(
    bearings: NDArray[np.float64], ranges: NDArray[np.float64], beta: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Closed form of eq. (18)-(21) for planar bearings beyond ``r_0``, shape (..., 2, 2).

    Parameters
    ----------
    bearings, ranges : ndarray, shape (..., M)
        ``theta_i`` (rad) and ``r_i`` (m, each > r_0).
    beta : ndarray, shape (M,) or broadcastable
        ``beta_i = sigma_i0^2 / r_0^2`` (rad^2 / m^2).
    """
    _, _, c, d = _abcd(ranges, beta)
    a_sum = c.sum(-1)  # A
    b1 = (d * np.cos(2.0 * bearings)).sum(-1)  # B_1
    b2 = (d * np.sin(2.0 * bearings)).sum(-1)  # B_2
    return 0.5 * np.stack([np.stack([a_sum + b1, b2], -1), np.stack([b2, a_sum - b1], -1)], -2)


def trace_from_angles(
    bearings: NDArray[np.float64], ranges: NDArray[np.float64], beta: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``tr(GCRLB)`` through the sensor-pair angles ``phi_ij``: eq. (25), corrected.

    .. math::
        f = \\frac{\\sum_i c_i}{\\sum_i a_i b_i + \\sum_{i<j} \\big(a_i b_j + a_j b_i
            + d_i d_j \\sin^2 \\phi_{ij}\\big)}

    The paper's eq. (25) omits the ``a_i b_j + a_j b_i`` terms (see the module
    docstring); they are angle-free, so eq. (26)-(28) are unaffected.
    Arguments as in :func:`planar_fisher_information`; returns shape (...).
    """
    a, b, c, d = _abcd(ranges, beta)
    phi = bearings[..., None, :] - bearings[..., :, None]  # phi_ij = theta_j - theta_i
    upper = np.triu(np.ones(phi.shape[-2:], dtype=bool), k=1)
    pair = a[..., :, None] * b[..., None, :] + a[..., None, :] * b[..., :, None]
    pair = pair + d[..., :, None] * d[..., None, :] * np.sin(phi) ** 2
    information: NDArray[np.float64] = c.sum(-1) / ((a * b).sum(-1) + np.where(upper, pair, 0.0).sum((-1, -2)))
    return information


def optimal_trace(sensor_count: int, range_m: float, sigma0_rad: float, reference_range_m: float) -> float:
    """Minimum of ``tr(GCRLB)`` over the angles for M equal sensors at one range beyond r_0.

    At the optimum ``B_1 = B_2 = 0`` (eq. 31: the bearings ``pi / M`` apart), so eq. (24)
    gives ``f* = 4 / (M c) = 4 beta r^4 / (M (2 beta r^2 + 1))`` with ``r = r_min``
    (the paper prints ``r_max``).
    """
    beta = sigma0_rad**2 / reference_range_m**2
    r2 = range_m**2
    return 4.0 * beta * r2 * r2 / (sensor_count * (2.0 * beta * r2 + 1.0))


def tracking_gcrlb(
    motion: LinearMotionModel,
    step_s: float,
    initial_information: NDArray[np.float64],
    sensors: Sequence[SensorModel],
    vehicle_xyz: NDArray[np.float64],
    target_states: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Bound on the tracking error covariance with eq. (15)-(17) as the measurement information.

    The Tichavsky recursion of :mod:`gcs.core.pcrlb`, written in covariance form,
    ``P_{k+1}^- = F J_k^{-1} F^T + Q``, ``J_{k+1} = (P_{k+1}^-)^{-1} + J_z(k+1)``,
    with ``J_z`` the generalised information of :func:`fisher_information` in the
    position block (every sensor detects at every step). Step 0 is the first scan:
    ``J_0 = initial_information + J_z(0)``; ``initial_information`` (n, n) is the
    prior's (e.g. only ``1 / sigma_v^2`` on the velocity, when the position comes
    from the first scan alone).

    Parameters
    ----------
    vehicle_xyz : ndarray, shape (K, M, 3)
    target_states : ndarray, shape (K, n)
        The true target states.

    Returns
    -------
    ndarray, shape (K, n, n)
    """
    f, q = motion.matrices(step_s)
    j_z = fisher_information(sensors, np.asarray(target_states, dtype=np.float64), vehicle_xyz)
    measured = np.zeros((len(j_z),) + f.shape)
    measured[:, :2, :2] = j_z  # the position block
    return information_recursion(f, q, initial_information, measured)
