"""Range / azimuth / elevation sensor of wang2012 eq. (3)-(4), and its subsets.

For a vehicle at ``p_i = (x_i, y_i, z_i)`` and the ground target at
``(x_t, y_t, z_t)`` (``z_t`` is the target's height, 0 on flat ground), with
the relative position ``d = p_t - p_i = (dx, dy, dz)``:

.. math::
    \\rho = \\sqrt{dx^2 + dy^2 + dz^2}, \\quad
    \\varphi = \\operatorname{atan2}(dy, dx), \\quad
    \\theta = \\operatorname{atan2}\\big(dz, \\sqrt{dx^2 + dy^2}\\big)      \\qquad (4)

Azimuth is from east, counter-clockwise, in (-pi, pi]; elevation is negative
when the target is below the vehicle. Measurements are ``z = H(x) + r``,
``r ~ N(0, R)`` with ``R`` diagonal (eq. 3). Azimuth residuals are wrapped
(``wrap_angle``), so a target crossing the +-pi seam is handled.

Noise: ``constant`` standard deviations, or zuo2021 eq. (2)
``sigma^2 = sigma0^2 rho^2 / rho0^2`` beyond the reference range ``rho0``
(constant inside it) for every component.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.models.components import AZIMUTH, ELEVATION, RANGE
from gcs.core.models.components import KNOWN_COMPONENTS as _KNOWN
from gcs.core.models.second_order import MIN_HORIZONTAL_M2, off_the_vertical, second_order_variance

__all__ = ["RANGE", "AZIMUTH", "ELEVATION", "DetectionGroup", "SensorModel"]



DetectionGroup = tuple["SensorModel", NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]
"""``(sensor, z (k, m), vehicle_xyz (k, 3), vehicle_cov)``: one sensor model's detections; ``vehicle_cov``: None,
per-axis variances (k,) or (k, 3, 3) covariances."""


@dataclass(frozen=True)
class SensorModel:
    """Which components a sensor measures, their noise, and the target's height.

    Parameters
    ----------
    components : tuple of str
        A subsequence of ``("range", "azimuth", "elevation")``; azimuth is required.
    std : tuple of float
        Standard deviation of each component (metres for range, radians for angles);
        for distance-dependent noise, the value at and inside ``reference_range_m``.
    distance_dependent : bool
        zuo2021 eq. (2) noise growth beyond ``reference_range_m``.
    reference_range_m : float
        ``rho0`` of zuo2021 eq. (2).
    target_height_m : float
        ENU height of the tracked point on the target (0 for a target on the ground).
    """

    components: tuple[str, ...]
    std: tuple[float, ...]
    distance_dependent: bool = False
    reference_range_m: float = 1500.0
    target_height_m: float = 0.0
    _az: int = field(init=False, repr=False, compare=False)
    _var: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _inv_var: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        order = [_KNOWN.index(c) for c in self.components if c in _KNOWN]
        if len(order) != len(self.components) or order != sorted(set(order)):
            raise ValueError(f"components must be an ordered subset of {_KNOWN}, got {self.components!r}")
        if AZIMUTH not in self.components:
            raise ValueError("a sensor must measure azimuth")
        if len(self.std) != len(self.components) or not all(s > 0 and np.isfinite(s) for s in self.std):
            raise ValueError(f"std must give one positive value per component, got {self.std!r}")
        object.__setattr__(self, "_az", self.components.index(AZIMUTH))
        object.__setattr__(self, "_var", np.asarray(self.std, dtype=np.float64) ** 2)
        object.__setattr__(self, "_inv_var", 1.0 / self._var)

    def __hash__(self) -> int:
        """Hashed once (per process: strings hash differently in each): the tracker groups every step's
        detections by sensor model."""
        cached = self.__dict__.get("_hash")
        if cached is None:
            cached = hash((self.components, self.std, self.distance_dependent, self.reference_range_m,
                           self.target_height_m))
            object.__setattr__(self, "_hash", cached)
        return cached

    def __getstate__(self) -> dict[str, object]:
        state = dict(self.__dict__)
        state.pop("_hash", None)  # another process hashes its strings differently
        return state

    @classmethod
    def range_bearing(cls, range_std_m: float, azimuth_std_rad: float, elevation_std_rad: float, *,
                      distance_dependent: bool = distance_dependent, reference_range_m: float = reference_range_m,
                      target_height_m: float = target_height_m) -> SensorModel:
        """The paper's 3-D sensor: range, azimuth and elevation (the options default to the fields' defaults)."""
        return cls((RANGE, AZIMUTH, ELEVATION), (range_std_m, azimuth_std_rad, elevation_std_rad),
                   distance_dependent=distance_dependent, reference_range_m=reference_range_m,
                   target_height_m=target_height_m)

    @classmethod
    def bearing_only(cls, azimuth_std_rad: float, elevation_std_rad: float | None = None, *,
                     distance_dependent: bool = distance_dependent, reference_range_m: float = reference_range_m,
                     target_height_m: float = target_height_m) -> SensorModel:
        """Angles only: azimuth, plus elevation when its noise is given (options as :meth:`range_bearing`)."""
        components, std = ((AZIMUTH,), (azimuth_std_rad,)) if elevation_std_rad is None else (
            (AZIMUTH, ELEVATION), (azimuth_std_rad, elevation_std_rad))
        return cls(components, std, distance_dependent=distance_dependent, reference_range_m=reference_range_m,
                   target_height_m=target_height_m)

    @property
    def dim(self) -> int:
        """Number of measured components m."""
        return len(self.components)

    @property
    def azimuth_index(self) -> int:
        """Position of the azimuth in a measurement vector."""
        return self._az

    def _relative(self, target_xy: NDArray[np.float64],
                  vehicle_xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                             NDArray[np.float64]]:
        dx = target_xy[..., 0] - vehicle_xyz[..., 0]
        dy = target_xy[..., 1] - vehicle_xyz[..., 1]
        dz = self.target_height_m - vehicle_xyz[..., 2]
        return dx, dy, dz

    def distance(self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
        """3-D distance ``rho`` from vehicles (..., 3) to target points (..., >=2)."""
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        return np.sqrt(dx * dx + dy * dy + dz * dz, dtype=np.float64)

    def measure(self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
        """Noise-free ``H(x)`` of eq. (4), vectorised.

        Parameters
        ----------
        target_xy : ndarray, shape (..., >=2)
            Target states or positions; only the first two entries (ENU x, y) are used.
        vehicle_xyz : ndarray, shape (..., 3)
            Vehicle ENU positions; broadcast against ``target_xy``'s leading axes.

        Returns
        -------
        ndarray, shape (..., m)
        """
        d = target_xy[..., :2] - vehicle_xyz[..., :2]
        dx, dy = d[..., 0], d[..., 1]
        dz = self.target_height_m - vehicle_xyz[..., 2]
        horizontal = np.hypot(dx, dy)
        out = np.empty(horizontal.shape + (self.dim,))
        for k, component in enumerate(self.components):
            if component == RANGE:
                out[..., k] = np.hypot(horizontal, dz)
            elif component == AZIMUTH:
                out[..., k] = np.arctan2(dy, dx)
            else:
                out[..., k] = np.arctan2(dz, horizontal)
        return out

    def jacobian(self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64], state_dim: int = 2) -> NDArray[np.float64]:
        """Analytic ``dH/dx`` of eq. (4) with respect to the target state, shape (..., m, state_dim).

        Only the position columns (0 and 1) are non-zero:
        ``d rho/dx = dx/rho``, ``d phi/dx = -dy/rho_h^2``, ``d theta/dx = -dz dx/(rho^2 rho_h)``
        and likewise for y, with ``rho_h`` the horizontal distance.
        """
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        h2 = dx * dx + dy * dy
        r2 = h2 + dz * dz
        h = np.sqrt(h2)
        rows = []
        for component in self.components:
            if component == RANGE:
                r = np.sqrt(r2)
                rows.append((dx / r, dy / r))
            elif component == AZIMUTH:
                rows.append((-dy / h2, dx / h2))
            else:
                rows.append((-dz * dx / (r2 * h), -dz * dy / (r2 * h)))
        shape = np.broadcast(dx, dy).shape
        jac = np.zeros(shape + (self.dim, state_dim))
        for row, (gx, gy) in enumerate(rows):
            jac[..., row, 0] = gx
            jac[..., row, 1] = gy
        return jac

    def vehicle_jacobian(self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
        """``dH/dp_s`` of eq. (4) with respect to the *vehicle's* position (x, y, z), shape (..., m, 3).

        ``H`` depends on ``d = p_t - p_s`` only, so ``dH/dp_s = -dH/dd`` with
        ``d rho/dd = d / rho``, ``d phi/dd = (-dy, dx, 0) / rho_h^2`` and
        ``d theta/dd = (-dz dx / (rho^2 rho_h), -dz dy / (rho^2 rho_h), rho_h / rho^2)``.
        """
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        h2 = dx * dx + dy * dy
        r2 = h2 + dz * dz
        h = np.sqrt(h2)
        shape = np.broadcast(dx, dy, dz).shape
        jac = np.zeros(shape + (self.dim, 3))
        for row, component in enumerate(self.components):
            grads: list[NDArray[np.float64] | float]
            if component == RANGE:
                r = np.sqrt(r2)
                grads = [dx / r, dy / r, dz / r]
            elif component == AZIMUTH:
                grads = [-dy / h2, dx / h2, 0.0]
            else:
                grads = [-dz * dx / (r2 * h), -dz * dy / (r2 * h), h / r2]
            for col, g in enumerate(grads):
                jac[..., row, col] = -g
        return jac

    def isotropic_vehicle_variance(self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
                                   per_axis_var: NDArray[np.float64]) -> NDArray[np.float64]:
        """``diag(J_s P_s J_s^T)``, shape (..., m), for ``P_s = s^2 I_3``: a vehicle position off by ``s`` per axis.

        The gradients of range, azimuth and elevation with respect to the vehicle
        (:meth:`vehicle_jacobian`) are mutually orthogonal, of lengths ``1``,
        ``1 / rho_h`` and ``1 / rho``; so ``J_s J_s^T`` is diagonal and the terms are
        ``s^2``, ``s^2 / rho_h^2`` and ``s^2 / rho^2``.
        """
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        h2 = np.maximum(dx * dx + dy * dy, MIN_HORIZONTAL_M2)
        var = np.asarray(per_axis_var, dtype=np.float64)
        out = np.empty(np.broadcast(h2, var).shape + (self.dim,))
        for k, component in enumerate(self.components):
            if component == RANGE:
                out[..., k] = var
            elif component == AZIMUTH:
                out[..., k] = var / h2
            else:
                out[..., k] = var / (h2 + dz * dz)
        return out

    def linearisation_variance(
        self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64], position_cov: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Variance the linearisation of eq. (4) leaves out, per component: shape (..., m)
        (:func:`gcs.core.models.second_order.second_order_variance`, where the maths is).

        ``target_xy`` (..., >=2): predicted target positions; ``vehicle_xyz`` (..., 3);
        ``position_cov`` (..., 2, 2): covariance of the relative horizontal position (the
        target's, plus the vehicle's own when it is uncertain).
        """
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        return second_order_variance(self.components, dx, dy, dz, position_cov)

    def fisher_information_xy(
        self, target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
        extra_variance: NDArray[np.float64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Fisher information ``H^T R^-1 H`` of one detection about the target's (x, y), closed form.

        With ``u`` the unit horizontal line of sight and ``v`` its left normal,
        ``H^T R^-1 H = alpha u u^T + beta v v^T`` where

        .. math::
            \\alpha = \\frac{\\rho_h^2}{\\rho^2 \\sigma_\\rho^2} + \\frac{dz^2}{\\rho^4 \\sigma_\\theta^2},
            \\quad \\beta = \\frac{1}{\\rho_h^2 \\sigma_\\varphi^2}

        (terms of components the sensor does not measure drop out; noise at the
        true range for distance-dependent sensors). ``extra_variance`` (..., m),
        e.g. :meth:`linearisation_variance`, is added to ``R``'s diagonal.

        Returns
        -------
        xx, xy, yy : ndarray, each shape (...)
            Entries of the symmetric 2 x 2 matrix.
        """
        dx, dy, dz = self._relative(target_xy, vehicle_xyz)
        dx, dy, h2 = off_the_vertical(dx, dy)  # straight above: finite, the azimuth's term very large
        r2 = h2 + dz * dz
        if extra_variance is None:
            inv_var = self.noise_information(None, target_xy, vehicle_xyz)
        else:
            inv_var = 1.0 / (self.noise_variance(None, target_xy, vehicle_xyz) + extra_variance)
        along = np.zeros(np.shape(h2))
        across = np.zeros(np.shape(h2))
        for k, component in enumerate(self.components):
            if component == RANGE:
                along = along + inv_var[..., k] * h2 / r2
            elif component == AZIMUTH:
                across = across + inv_var[..., k] / h2
            else:
                along = along + inv_var[..., k] * dz * dz / (r2 * r2)
        # alpha u u^T + beta v v^T with u = (dx, dy)/rho_h, v = (-dy, dx)/rho_h
        along_h = along / h2
        across_h = across / h2
        xx = along_h * dx * dx + across_h * dy * dy
        yy = along_h * dy * dy + across_h * dx * dx
        xy = (along_h - across_h) * dx * dy
        return xx, xy, yy

    def noise_variance(
        self,
        z_pred: NDArray[np.float64] | None = None,
        target_xy: NDArray[np.float64] | None = None,
        vehicle_xyz: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """Diagonal of ``R`` (m,), or (..., m) for distance-dependent noise.

        Distance-dependent noise (zuo2021 eq. 2) is evaluated at the predicted
        range: the range component of ``z_pred`` when measured, otherwise the
        distance from ``vehicle_xyz`` to ``target_xy``.
        """
        var = self._var
        if not self.distance_dependent:
            return var
        if z_pred is not None and self.components[0] == RANGE:
            ranges = z_pred[..., 0]
        elif target_xy is not None and vehicle_xyz is not None:
            ranges = self.distance(target_xy, vehicle_xyz)
        else:
            raise ValueError("distance-dependent noise needs the predicted range (z_pred with a range component) "
                             "or target_xy and vehicle_xyz")
        scale = np.maximum(np.asarray(ranges, dtype=np.float64) / self.reference_range_m, 1.0) ** 2
        scaled: NDArray[np.float64] = var * scale[..., None]
        return scaled

    def noise_information(
        self,
        z_pred: NDArray[np.float64] | None = None,
        target_xy: NDArray[np.float64] | None = None,
        vehicle_xyz: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """Diagonal of ``R^-1``; same arguments as :meth:`noise_variance`."""
        if not self.distance_dependent:
            return self._inv_var
        return 1.0 / self.noise_variance(z_pred, target_xy, vehicle_xyz)

    def residual(self, z: NDArray[np.float64], z_pred: NDArray[np.float64]) -> NDArray[np.float64]:
        """``z - z_pred`` with the azimuth component wrapped to (-pi, pi]."""
        diff = np.asarray(z - z_pred, dtype=np.float64)
        diff[..., self.azimuth_index] = wrap_angle(diff[..., self.azimuth_index])
        return diff
