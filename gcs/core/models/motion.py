"""Linear target motion models of wang2012 eq. (2): x[k+1] = F x[k] + q[k], q ~ N(0, Q).

Two state layouts, both ordered by derivative blocks of the ENU x and y axes:

* ``cv2d``: ``[x, y, vx, vy]``, the discretised continuous white-noise
  acceleration model (Bar-Shalom, Li, Kirubarajan 2001, section 6.2.2). With
  acceleration noise power spectral density ``q`` (m^2/s^3) and step ``T``:

  .. math::
      F = \\begin{bmatrix} 1 & T \\\\ 0 & 1 \\end{bmatrix} \\otimes I_2, \\quad
      Q = q \\begin{bmatrix} T^3/3 & T^2/2 \\\\ T^2/2 & T \\end{bmatrix} \\otimes I_2

* ``ca2d``: ``[x, y, vx, vy, ax, ay]``, the paper's position/velocity/acceleration
  state with white-noise jerk of density ``q`` (m^2/s^5), the Wiener-process
  acceleration model:

  .. math::
      F = \\begin{bmatrix} 1 & T & T^2/2 \\\\ 0 & 1 & T \\\\ 0 & 0 & 1 \\end{bmatrix} \\otimes I_2,
      \\quad
      Q = q \\begin{bmatrix} T^5/20 & T^4/8 & T^3/6 \\\\ T^4/8 & T^3/3 & T^2/2 \\\\
                             T^3/6 & T^2/2 & T \\end{bmatrix} \\otimes I_2

Both are linear, so the unscented prediction of the filters reproduces
``F x`` and ``F P F^T + Q`` exactly; the filters use those closed forms.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["LinearMotionModel", "constant_velocity", "constant_acceleration", "motion_model"]

_I2 = np.eye(2)


@lru_cache(maxsize=64)
def _cv_matrices(dt: float, q: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    f = np.kron(np.array([[1.0, dt], [0.0, 1.0]]), _I2)
    qm = q * np.kron(np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]]), _I2)
    f.flags.writeable = False
    qm.flags.writeable = False
    return f, qm


@lru_cache(maxsize=64)
def _ca_matrices(dt: float, q: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    f1 = np.array([[1.0, dt, dt**2 / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    q1 = np.array(
        [
            [dt**5 / 20.0, dt**4 / 8.0, dt**3 / 6.0],
            [dt**4 / 8.0, dt**3 / 3.0, dt**2 / 2.0],
            [dt**3 / 6.0, dt**2 / 2.0, dt],
        ]
    )
    f = np.kron(f1, _I2)
    qm = q * np.kron(q1, _I2)
    f.flags.writeable = False
    qm.flags.writeable = False
    return f, qm


MatricesBuilder = Callable[[float, float], tuple[NDArray[np.float64], NDArray[np.float64]]]
"""``(dt, q) -> (F, Q)`` of one motion model."""


@lru_cache(maxsize=64)
def _horizon_matrices(build: MatricesBuilder, dt: float, q: float,
                      steps: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    f, qm = build(dt, q)
    powers, noises = [f], [qm]
    for _ in range(steps - 1):
        powers.append(f @ powers[-1])
        noises.append(f @ noises[-1] @ f.T + qm)
    stacked = np.stack(powers), np.stack(noises)
    for array in stacked:
        array.flags.writeable = False
    return stacked


@dataclass(frozen=True)
class LinearMotionModel:
    """A linear Gaussian motion model x[k+1] = F(T) x[k] + q, q ~ N(0, Q(T)).

    Attributes
    ----------
    name : str
        ``"cv2d"`` or ``"ca2d"``.
    dim : int
        State dimension (4 or 6).
    noise_density : float
        ``q``: acceleration (cv2d, m^2/s^3) or jerk (ca2d, m^2/s^5) power spectral density.
    """

    name: str
    dim: int
    noise_density: float

    position_slice = slice(0, 2)
    """State indices of the ENU position (x, y)."""
    velocity_slice = slice(2, 4)
    """State indices of the ENU velocity (vx, vy)."""

    def __post_init__(self) -> None:
        if self.name not in ("cv2d", "ca2d"):
            raise ValueError(f"unknown motion model {self.name!r}; expected 'cv2d' or 'ca2d'")
        if self.dim != (4 if self.name == "cv2d" else 6):
            raise ValueError(f"{self.name} has dimension {4 if self.name == 'cv2d' else 6}, not {self.dim}")
        if not (self.noise_density >= 0.0 and np.isfinite(self.noise_density)):
            raise ValueError(f"noise_density must be finite and >= 0, got {self.noise_density!r}")

    def matrices(self, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(F, Q)`` for a step of ``dt`` seconds (read-only arrays, cached)."""
        if not dt > 0.0:
            raise ValueError(f"time step must be positive, got {dt!r}")
        return self._build(float(dt), float(self.noise_density))

    @property
    def _build(self) -> MatricesBuilder:
        """The cached ``(F, Q)`` builder of this model."""
        return _cv_matrices if self.name == "cv2d" else _ca_matrices

    def horizon_matrices(self, dt: float, steps: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(F^j, Q_j)`` for j = 1..steps steps of ``dt``, stacked (steps, dim, dim) (read-only, cached).

        ``x[k+j] = F^j x[k]`` and ``P[k+j] = F^j P[k] (F^j)^T + Q_j`` with
        ``Q_1 = Q`` and ``Q_j = F Q_{j-1} F^T + Q``: the covariance carried along
        wang2012 eq. (17), j steps at once.
        """
        if not dt > 0.0:
            raise ValueError(f"time step must be positive, got {dt!r}")
        if steps < 1:
            raise ValueError(f"steps must be >= 1, got {steps}")
        return _horizon_matrices(self._build, float(dt), float(self.noise_density), int(steps))

    def propagate(self, states: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """Noise-free transition ``F x`` of states with shape (..., dim) (wang2012 eq. 17)."""
        f, _ = self.matrices(dt)
        propagated: NDArray[np.float64] = states @ f.T
        return propagated


def constant_velocity(accel_psd_m2_s3: float) -> LinearMotionModel:
    """The 4-D ``cv2d`` white-noise acceleration model."""
    return LinearMotionModel("cv2d", 4, accel_psd_m2_s3)


def constant_acceleration(jerk_psd_m2_s5: float) -> LinearMotionModel:
    """The paper's 6-D ``ca2d`` position/velocity/acceleration model."""
    return LinearMotionModel("ca2d", 6, jerk_psd_m2_s5)


def motion_model(name: str, noise_density: float) -> LinearMotionModel:
    """Build a model by its scenario name (``cv2d`` or ``ca2d``)."""
    return LinearMotionModel(name, 4 if name == "cv2d" else 6, noise_density)
