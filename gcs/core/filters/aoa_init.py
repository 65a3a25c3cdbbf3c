"""A scan of bearings from several sensors, and the target's initial estimate from it (zuo2021 section 2.3 (1)).

One *scan* is the measurements ``z_i`` (eq. 1, 3) that the sensors ``i = 1..M`` took at
the same time from ``S_i``; :class:`AoaScan` stacks them into one vector
``theta = theta^0(p) + n`` (eq. 3) with the diagonal, distance-dependent noise of
eq. (2), and is what the filters (:mod:`~gcs.core.filters.vgukf`,
:mod:`~gcs.core.filters.aoa_ekf`) and the initialisers below evaluate.

Initialisers (the paper's step (1) and its least-squares baseline):

* :func:`pseudo_linear_initialise`: the pseudo-linear least-squares intersection of
  the bearing lines. Each bearing gives the linear equation
  ``sin(theta_i) x - cos(theta_i) y = sin(theta_i) x_i - cos(theta_i) y_i``
  whose error is ``r_i sin(n_i)``; unweighted least squares (Nguyen & Dogancay 2017,
  the paper's ref. [4]). Biased, since the regressors hold the noise.
* :func:`ml_initialise`: the maximum-likelihood position (Gavish & Weiss 1992, the
  paper's ref. [2]) under the distance-dependent noise of eq. (2), started from the
  pseudo-linear solution. The negative log-likelihood is

  .. math::
      -\\log L(p) = \\sum_k \\frac{(z_k - h_k(p))^2}{2 \\sigma_k^2(p)}
                   + \\tfrac12 \\sum_k \\log \\sigma_k^2(p) + \\text{const}

  and the second sum is ``sum_i m_i log s_i(p) / 2`` with ``s = max(rho / rho_0, 1)^2 >= 1``.
  Both are sums of squares, ``e_k = (z_k - h_k) / sigma_k`` and
  ``g_i = sqrt(m_i log s_i + 1)`` (the constant 1 keeps ``g`` smooth and moves only
  the cost), so ``scipy.optimize.least_squares`` minimises the exact likelihood.
  The covariance is the inverse Fisher information at the solution, eq. (15)-(17)
  (:func:`gcs.core.gcrlb.fisher_information`).

A single scan says nothing about the velocity: both initialisers return the
velocity ``0`` with the prior standard deviation ``velocity_std_mps`` per axis (the
state is ``[x, y, vx, vy]``, the ``cv2d`` layout of :mod:`gcs.core.models.motion`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from gcs.core.filters.uif import GaussianEstimate
from gcs.core.gcrlb import fisher_information, log_variance_gradient
from gcs.core.geometry import wrap_angle
from gcs.core.models.sensor import SensorModel

__all__ = ["AoaScan", "pseudo_linear_position", "pseudo_linear_initialise", "negative_log_likelihood", "ml_initialise"]


@dataclass(frozen=True)
class AoaScan:
    """The stacked measurements of M sensors taken at one time.

    Parameters
    ----------
    sensors : tuple of SensorModel, length M
    z : ndarray, shape (sum_i m_i,)
        The measurements of sensor 1, then sensor 2, ... (one bearing each for
        azimuth-only sensors).
    positions : ndarray, shape (M, 3)
        ENU sensor positions ``S_i`` (m).
    """

    sensors: tuple[SensorModel, ...]
    z: NDArray[np.float64]
    positions: NDArray[np.float64]

    @classmethod
    def of(cls, sensors: Sequence[SensorModel], z: NDArray[np.float64] | Sequence[ArrayLike], sensor_xyz: ArrayLike) -> AoaScan:
        """Build a scan; ``z`` is (M,) for azimuth-only sensors, (M, m) or a list of per-sensor vectors."""
        stacked = np.concatenate([np.atleast_1d(np.asarray(zi, dtype=np.float64)) for zi in z])
        positions = np.asarray(sensor_xyz, dtype=np.float64).reshape(len(sensors), 3)
        if stacked.size != sum(s.dim for s in sensors):
            raise ValueError(f"{stacked.size} measurements for sensors of dimension {[s.dim for s in sensors]}")
        return cls(tuple(sensors), stacked, positions)

    def measure(self, states: NDArray[np.float64]) -> NDArray[np.float64]:
        """Noise-free ``theta^0`` of eq. (3) at target states (..., >=2): shape (..., sum m_i)."""
        return np.concatenate([s.measure(states, xyz) for s, xyz in zip(self.sensors, self.positions)], axis=-1)

    def residual(self, z_pred: NDArray[np.float64], z: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """``z - z_pred`` (``z`` defaults to the scan's), every azimuth wrapped to (-pi, pi]."""
        diff = np.array((self.z if z is None else z) - z_pred, dtype=np.float64)
        k = self.azimuth_indices
        diff[..., k] = wrap_angle(diff[..., k])
        return diff

    def variance(self, target_xy: NDArray[np.float64], distance_dependent: bool = True) -> NDArray[np.float64]:
        """Diagonal of ``R_r`` (..., sum m_i): eq. (2) at ``target_xy``, or the constant ``sigma_0^2``."""
        if not distance_dependent:
            return np.concatenate([np.square(s.std) for s in self.sensors])
        lead = np.shape(target_xy)[:-1]
        return np.concatenate(
            [np.broadcast_to(s.noise_variance(None, target_xy, xyz), lead + (s.dim,))
             for s, xyz in zip(self.sensors, self.positions)],
            axis=-1,
        )

    def jacobian(self, states: NDArray[np.float64], state_dim: int) -> NDArray[np.float64]:
        """``d theta^0 / d x`` at states (..., >=2): shape (..., sum m_i, state_dim)."""
        return np.concatenate(
            [s.jacobian(states, xyz, state_dim) for s, xyz in zip(self.sensors, self.positions)], axis=-2
        )

    def log_variance_gradient(self, target_xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """``grad log s_i`` (eq. 2) of each sensor, shape (M, 2)."""
        return np.stack([log_variance_gradient(s, target_xy, xyz) for s, xyz in zip(self.sensors, self.positions)])

    def log_scale(self, target_xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """``log s_i = 2 log max(rho_i / rho_0, 1)`` of eq. (2) (0 for constant noise), shape (M,)."""
        scale = [
            max(float(s.distance(target_xy, xyz)) / s.reference_range_m, 1.0) if s.distance_dependent else 1.0
            for s, xyz in zip(self.sensors, self.positions)
        ]
        return 2.0 * np.log(scale)

    @property
    def dims(self) -> NDArray[np.int_]:
        """Number of components ``m_i`` of each sensor, shape (M,)."""
        return np.array([s.dim for s in self.sensors])

    @property
    def owner(self) -> NDArray[np.int_]:
        """Index of the sensor of each stacked component, shape (sum m_i,)."""
        return np.repeat(np.arange(len(self.sensors)), self.dims)

    @property
    def azimuth_indices(self) -> NDArray[np.int_]:
        """Position of each sensor's azimuth in the stacked vector, shape (M,)."""
        indices: NDArray[np.int_] = np.cumsum(self.dims) - self.dims + np.array([s.azimuth_index for s in self.sensors])
        return indices


def _with_velocity(
    position: NDArray[np.float64], position_cov: NDArray[np.float64], velocity_std_mps: float, stamp_ns: int
) -> GaussianEstimate:
    """``[x, y, 0, 0]`` with the position covariance and ``velocity_std_mps^2 I`` on the velocity."""
    if not velocity_std_mps > 0.0:
        raise ValueError(f"velocity_std_mps must be positive, got {velocity_std_mps!r}")
    mean = np.concatenate([position, np.zeros(2)])
    cov = np.zeros((4, 4))
    cov[:2, :2] = 0.5 * (position_cov + position_cov.T)
    cov[2:, 2:] = velocity_std_mps**2 * np.eye(2)
    return GaussianEstimate(mean, cov, stamp_ns)


def _bearing_rows(scan: AoaScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pseudo-linear rows ``a_i = (sin theta_i, -cos theta_i)`` (M, 2) and right-hand sides ``a_i . S_i`` (M,)."""
    theta = scan.z[scan.azimuth_indices]
    rows = np.stack([np.sin(theta), -np.cos(theta)], axis=-1)
    return rows, np.einsum("ij,ij->i", rows, scan.positions[:, :2])


def pseudo_linear_position(scan: AoaScan) -> NDArray[np.float64]:
    """Least-squares intersection of the bearing lines, shape (2,); needs two non-parallel bearings."""
    rows, rhs = _bearing_rows(scan)
    solution, *_ = np.linalg.lstsq(rows, rhs, rcond=None)
    return solution.astype(np.float64, copy=False)


def pseudo_linear_initialise(
    sensors: Sequence[SensorModel],
    z: NDArray[np.float64] | Sequence[ArrayLike],
    sensor_xyz: ArrayLike,
    stamp_ns: int,
    velocity_std_mps: float,
) -> GaussianEstimate:
    """Least-squares initial estimate (the LS-EKF baseline's; zuo2021 ref. [4], [16]).

    The position is the unweighted pseudo-linear solution ``p = (A^T A)^-1 A^T b``
    (module docstring). Its covariance is the sandwich
    ``(A^T A)^-1 A^T W A (A^T A)^-1`` with ``W = diag(r_i^2 sigma_i^2)`` the variance
    of the equation errors ``r_i sin(n_i)``, ``r_i`` and ``sigma_i`` (eq. 2) taken at
    the solution. Only the azimuth of each sensor is used.

    Parameters
    ----------
    sensors : sequence of SensorModel, length M (M >= 2)
    z : measurements, see :meth:`AoaScan.of`
    sensor_xyz : array_like, shape (M, 3)
    stamp_ns : int
        Time of the scan.
    velocity_std_mps : float
        Prior standard deviation of each velocity component (the mean is 0).
    """
    scan = AoaScan.of(sensors, z, sensor_xyz)
    rows, _ = _bearing_rows(scan)
    position = pseudo_linear_position(scan)
    ranges = np.linalg.norm(position - scan.positions[:, :2], axis=1)
    weights = ranges**2 * scan.variance(position)[scan.azimuth_indices]
    normal_inv = np.linalg.inv(rows.T @ rows)
    cov = normal_inv @ (rows.T * weights) @ rows @ normal_inv
    return _with_velocity(position, cov, velocity_std_mps, stamp_ns)


def _ml_residuals(scan: AoaScan, position: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Residuals ``[e_k, g_i]`` of the likelihood and their Jacobian (module docstring)."""
    sigma = np.sqrt(scan.variance(position))
    res = scan.residual(scan.measure(position))
    grad_log_s = scan.log_variance_gradient(position)  # (M, 2)
    dims = scan.dims
    g = np.sqrt(dims * scan.log_scale(position) + 1.0)
    # d e_k/dp = -(grad h_k + e_k sigma_k grad log sigma_k) / sigma_k with grad log sigma_k = grad log s / 2
    e = res / sigma
    jac_e = -(scan.jacobian(position, 2) / sigma[:, None] + 0.5 * e[:, None] * grad_log_s[scan.owner])
    jac_g = dims[:, None] * grad_log_s / (2.0 * g[:, None])
    return np.concatenate([e, g]), np.concatenate([jac_e, jac_g])


def negative_log_likelihood(scan: AoaScan, position: NDArray[np.float64]) -> float:
    """``-log L(p)`` up to a constant (module docstring), for comparing candidate positions."""
    residuals, _ = _ml_residuals(scan, np.asarray(position, dtype=np.float64))
    return 0.5 * float(residuals @ residuals)


def ml_initialise(
    sensors: Sequence[SensorModel],
    z: NDArray[np.float64] | Sequence[ArrayLike],
    sensor_xyz: ArrayLike,
    stamp_ns: int,
    velocity_std_mps: float,
    max_range_m: float = 20_000.0,
) -> GaussianEstimate:
    """Maximum-likelihood initial estimate of the target (zuo2021 step (1), ref. [2]).

    Minimises the exact negative log-likelihood under eq. (2) noise (module
    docstring) with ``scipy.optimize.least_squares`` (Levenberg-Marquardt), from the
    pseudo-linear intersection. When that start lies behind a sensor (a bearing
    off by more than 90 deg, which happens when noisy lines meet behind the
    sensors) or beyond ``max_range_m``, the start is instead the best of points on
    the mean bearing from the sensors' centroid, at ranges from 500 m to
    ``max_range_m``. The covariance is ``J^-1`` of eq. (15)-(17) at the solution.

    Parameters
    ----------
    sensors, z, sensor_xyz, stamp_ns, velocity_std_mps
        As in :func:`pseudo_linear_initialise`.
    max_range_m : float
        Detection range: farther starts are not trusted.
    """
    scan = AoaScan.of(sensors, z, sensor_xyz)
    start = pseudo_linear_position(scan)
    behind = np.abs(scan.residual(scan.measure(start))[scan.azimuth_indices]) > 0.5 * np.pi
    far = np.linalg.norm(start - scan.positions[:, :2], axis=1).max() > max_range_m
    if not np.all(np.isfinite(start)) or behind.any() or far:
        rows, _ = _bearing_rows(scan)
        heading = np.arctan2(rows[:, 0].mean(), -rows[:, 1].mean())  # direction of the mean of (cos, sin) theta_i
        centroid = scan.positions[:, :2].mean(axis=0)
        ranges = np.geomspace(500.0, max_range_m, 24)
        candidates = centroid + ranges[:, None] * np.array([np.cos(heading), np.sin(heading)])
        start = min(candidates, key=lambda p: negative_log_likelihood(scan, p))
    last: dict[bytes, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def evaluate(p: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        key = p.tobytes()  # the optimiser asks for residuals and Jacobian at the same point
        if key not in last:
            last.clear()
            last[key] = _ml_residuals(scan, p)
        return last[key]

    def residuals(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return evaluate(p)[0]

    def jacobian(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return evaluate(p)[1]

    solution = least_squares(
        residuals,
        start,
        jac=jacobian,
        method="lm",
        x_scale="jac",
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
    )
    position = solution.x.astype(np.float64, copy=False)
    cov = np.linalg.inv(fisher_information(scan.sensors, position, scan.positions)).astype(np.float64, copy=False)
    return _with_velocity(position, cov, velocity_std_mps, stamp_ns)
