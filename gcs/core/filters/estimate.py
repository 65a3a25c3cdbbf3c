"""The target estimate the filters take and return: mean, covariance, stamp, and the layout of its state.

Conventions every filter of :mod:`gcs.core.filters` follows, checked when an
estimate is built:

* **Time is integer nanoseconds** (``stamp_ns``, as on the wire). A float is
  refused rather than read as nanoseconds: ``predict(estimate, 1.0)`` would
  otherwise predict 1 ns. Seconds convert with :func:`ns_from_s`.
* **The state layout is named** (:class:`StateLayout`): position first, then
  velocity (then acceleration, or the turn rate), each as ENU x then y, SI
  units. The layout follows from the state's dimension (:data:`LAYOUTS`) unless
  given; ``estimate.layout.index("vx_mps")`` says where a component is.
* Shapes: ``mean`` (..., n) and ``cov`` (..., n, n), float64; a leading axis
  may hold several estimates (the k+1..k+n predictions).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

__all__ = ["StateLayout", "CV2D", "CT2D", "CA2D", "LAYOUTS", "GaussianEstimate", "NotPositiveDefinite",
           "check_stamp_ns", "ns_from_s", "NS_PER_S"]

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class StateLayout:
    """What each entry of a state vector is: ``components`` in order, each named with its unit."""

    name: str
    components: tuple[str, ...]

    @property
    def dim(self) -> int:
        """Number of state entries."""
        return len(self.components)

    def index(self, component: str) -> int:
        """Where ``component`` (e.g. ``"vx_mps"``) is in the state; ValueError naming the layout's components."""
        try:
            return self.components.index(component)
        except ValueError:
            raise ValueError(f"{self.name} has no component {component!r}; it has {', '.join(self.components)}") \
                from None


CV2D = StateLayout("cv2d", ("x_m", "y_m", "vx_mps", "vy_mps"))
"""Constant velocity (:func:`gcs.core.models.motion.constant_velocity`), the daemon's default."""
CT2D = StateLayout("ct2d", ("x_m", "y_m", "vx_mps", "vy_mps", "omega_rad_s"))
"""Coordinated turn: constant velocity plus the turn rate (the IMM's modes, :mod:`gcs.core.filters.imm_target`)."""
CA2D = StateLayout("ca2d", ("x_m", "y_m", "vx_mps", "vy_mps", "ax_mps2", "ay_mps2"))
"""Constant acceleration (:func:`gcs.core.models.motion.constant_acceleration`), wang2012's state."""
LAYOUTS = {layout.dim: layout for layout in (CV2D, CT2D, CA2D)}
"""The layout of a state of each dimension unless an estimate names another."""
BY_DIMENSION = StateLayout("by dimension", ())
"""The default ``layout`` of a :class:`GaussianEstimate`: the one :data:`LAYOUTS` gives its dimension (an estimate
never keeps this one)."""


def check_stamp_ns(stamp_ns: object, name: str = "stamp_ns") -> int:
    """``stamp_ns`` as a Python int; TypeError for anything but an integer (a float in seconds, above all)."""
    if type(stamp_ns) is int:  # the common case, first
        return stamp_ns
    if isinstance(stamp_ns, (bool, np.bool_)) or not isinstance(stamp_ns, numbers.Integral):
        hint = (f"; for {stamp_ns!r} seconds pass ns_from_s({stamp_ns!r}) = {ns_from_s(stamp_ns)}"
                if isinstance(stamp_ns, float) and math.isfinite(stamp_ns) else "")
        raise TypeError(f"{name} must be an integer number of nanoseconds, got {type(stamp_ns).__name__} "
                        f"{stamp_ns!r}{hint}")
    return int(stamp_ns)


def ns_from_s(seconds: float) -> int:
    """Seconds to integer nanoseconds (rounded to the nearest)."""
    return round(seconds * NS_PER_S)


def _float_array(value: object, name: str) -> NDArray[np.float64]:
    if isinstance(value, np.ndarray) and value.dtype == np.float64:
        return value
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__}: {error}") from None
    return array


class NotPositiveDefinite(ValueError):
    """A covariance or information matrix lost positive definiteness."""


def cholesky(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower Cholesky factor; LAPACK directly for one matrix, numpy for a stack."""
    if matrix.ndim == 2:
        factor, info = lapack.dpotrf(matrix, lower=1, clean=1)
        if info != 0:
            raise NotPositiveDefinite(f"matrix is not positive definite (LAPACK dpotrf info={info})")
        lower: NDArray[np.float64] = factor
        return lower
    return np.linalg.cholesky(matrix).astype(np.float64, copy=False)


def triangular_inverse(lower: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverse of a lower-triangular matrix (or a stack of them)."""
    if lower.ndim == 2:
        inverse, info = lapack.dtrtri(lower, lower=1)
        if info != 0:
            raise NotPositiveDefinite(f"singular triangular factor (LAPACK dtrtri info={info})")
        inverse_2d: NDArray[np.float64] = inverse
        return inverse_2d
    return np.linalg.inv(lower).astype(np.float64, copy=False)


@dataclass(frozen=True)
class GaussianEstimate:
    """A target estimate: mean (..., n), covariance (..., n, n), its time (integer ns) and its state layout.

    Built from anything array-like (converted to float64); TypeError for a
    stamp that is not an integer, ValueError for shapes that do not match or a
    layout of another dimension. ``layout`` defaults to :data:`LAYOUTS`'s for
    the dimension (``[x, y, vx, vy]`` for 4). A leading axis may hold several
    estimates (the k+1..k+n predictions). The factors of the position block
    are computed once, on first use.
    """

    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    stamp_ns: int
    layout: StateLayout = field(default=BY_DIMENSION, kw_only=True)

    def __post_init__(self) -> None:
        mean, cov = _float_array(self.mean, "mean"), _float_array(self.cov, "cov")
        if mean.ndim == 0:
            raise ValueError("mean must have shape (..., n), got a scalar")
        n = mean.shape[-1]
        if cov.shape != mean.shape + (n,):
            raise ValueError(f"cov must have shape {mean.shape + (n,)} for a mean of shape {mean.shape}, "
                             f"got {cov.shape}")
        layout = self.layout if self.layout is not BY_DIMENSION else LAYOUTS.get(n)
        if layout is None:
            raise ValueError(f"no state layout for a {n}-dimensional state (known: "
                             f"{', '.join(f'{d} {lay.name}' for d, lay in LAYOUTS.items())}); pass layout=")
        if not isinstance(layout, StateLayout) or layout.dim != n:
            raise ValueError(f"layout {layout!r} does not describe a {n}-dimensional state")
        stamp = check_stamp_ns(self.stamp_ns)
        if mean is not self.mean:
            object.__setattr__(self, "mean", mean)
        if cov is not self.cov:
            object.__setattr__(self, "cov", cov)
        if stamp is not self.stamp_ns:
            object.__setattr__(self, "stamp_ns", stamp)
        if layout is not self.layout:
            object.__setattr__(self, "layout", layout)

    @classmethod
    def computed(cls, mean: NDArray[np.float64], cov: NDArray[np.float64], stamp_ns: int,
                 layout: StateLayout) -> GaussianEstimate:
        """An estimate a filter computed from a checked one (float64 arrays of matching shapes, an int stamp, the
        same layout), built without checking them again: the filters' inner loop."""
        estimate = object.__new__(GaussianEstimate)
        estimate.__dict__.update(mean=mean, cov=cov, stamp_ns=stamp_ns, layout=layout)
        return estimate

    @property
    def dim(self) -> int:
        """State dimension ``n``."""
        return int(self.mean.shape[-1])

    @property
    def position(self) -> NDArray[np.float64]:
        """The ENU position ``[x, y]`` (m), shape (..., 2)."""
        return self.mean[..., :2]

    @property
    def velocity(self) -> NDArray[np.float64]:
        """The ENU velocity ``[vx, vy]`` (m/s), shape (..., 2)."""
        return self.mean[..., 2:4]

    @cached_property
    def _position_factors(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Closed-form lower Cholesky factor of the 2 x 2 position block and its inverse.

        ``L = [[a, 0], [b, d]]`` with ``a = sqrt(P_xx)``, ``b = P_xy / a``,
        ``d = sqrt(P_yy - b^2)``; ``L^-1 = [[1/a, 0], [-b/(a d), 1/d]]``.
        """
        cov = self.cov
        if cov.ndim == 2:  # one estimate: plain floats beat array calls at this size
            pxx, pxy, pyy = float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])
            if not pxx > 0.0:
                raise NotPositiveDefinite(f"position variance is not positive: {pxx!r}")
            a = math.sqrt(pxx)
            b = pxy / a
            rest = pyy - b * b
            if not rest > 0.0:
                raise NotPositiveDefinite("position covariance is not positive definite")
            d = math.sqrt(rest)
            return np.array([[a, 0.0], [b, d]]), np.array([[1.0 / a, 0.0], [-b / (a * d), 1.0 / d]])
        factor = cholesky(cov[..., :2, :2])
        return factor, triangular_inverse(factor)

    @property
    def position_cholesky(self) -> NDArray[np.float64]:
        """Lower factor ``L_pp`` of the position block ``P_pp`` (the first two states)."""
        return self._position_factors[0]

    @property
    def position_cholesky_inverse(self) -> NDArray[np.float64]:
        """``L_pp^-1``."""
        return self._position_factors[1]

    @property
    def information_matrix(self) -> NDArray[np.float64]:
        """``Y = P^-1 = L^-T L^-1`` with ``P = L L^T`` (wang2012 eq. 7)."""
        inv = triangular_inverse(cholesky(self.cov))
        return np.swapaxes(inv, -1, -2) @ inv
