"""Angles and frames: the one ``wrap_angle``, and WGS84 <-> local ENU about an origin.

Frames (docs/design.md, frames, units and time)
-----------------------------------------------
* Inside the core every position is metres in a local **ENU** frame (x east,
  y north, z up) whose origin is the scenario's geodetic origin.
* Azimuths are ``atan2(dy, dx)`` in that frame: from east, counter-clockwise.
* Geodetic coordinates are WGS84 latitude/longitude in degrees and height in
  metres above the ellipsoid. (MAVLink altitudes are AMSL or relative to home;
  the MAVLink adapter converts those to the ellipsoid height it passes here.)

The conversion goes through Earth-centred Earth-fixed (ECEF) coordinates and is
exact (no flat-Earth approximation): ENU -> geodetic uses Heikkinen's closed-form
ECEF -> geodetic solution, accurate to well below a millimetre at aircraft
altitudes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "WGS84_A",
    "WGS84_F",
    "LocalFrame",
    "wrap_angle",
    "geodetic_to_ecef",
    "ecef_to_geodetic",
]

WGS84_A = 6378137.0
"""WGS84 semi-major axis a, metres."""
WGS84_F = 1.0 / 298.257223563
"""WGS84 flattening f."""
WGS84_B = WGS84_A * (1.0 - WGS84_F)
"""WGS84 semi-minor axis b = a (1 - f), metres."""
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
"""First eccentricity squared e^2 = f (2 - f)."""
_EP2 = (WGS84_A**2 - WGS84_B**2) / WGS84_B**2
"""Second eccentricity squared e'^2 = (a^2 - b^2) / b^2."""


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: NDArray[np.float64]) -> NDArray[np.float64]: ...
@overload
def wrap_angle(angle: ArrayLike) -> NDArray[np.float64] | float: ...


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap angles to the half-open interval (-pi, pi].

    Every angle residual in the project goes through this function.

    Parameters
    ----------
    angle : float or array_like
        Angles in radians, any magnitude.

    Returns
    -------
    float or ndarray
        ``angle + 2 pi k`` in (-pi, pi], same shape as the input; a Python float
        for a scalar input.
    """
    a = np.asarray(angle, dtype=np.float64)
    wrapped = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def geodetic_to_ecef(lat_deg: ArrayLike, lon_deg: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
    """WGS84 geodetic coordinates to ECEF.

    .. math::
        N = a / \\sqrt{1 - e^2 \\sin^2\\phi}, \\quad
        X = (N + h)\\cos\\phi\\cos\\lambda, \\;
        Y = (N + h)\\cos\\phi\\sin\\lambda, \\;
        Z = (N (1 - e^2) + h)\\sin\\phi

    Returns
    -------
    ndarray, shape (..., 3)
        ECEF metres.
    """
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    h = np.asarray(height_m, dtype=np.float64)
    sin_lat, cos_lat = np.sin(lat), np.cos(lat)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sin_lat**2)
    x = (n + h) * cos_lat * np.cos(lon)
    y = (n + h) * cos_lat * np.sin(lon)
    z = (n * (1.0 - WGS84_E2) + h) * sin_lat
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def ecef_to_geodetic(ecef: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """ECEF to WGS84 geodetic by Heikkinen's closed form (exact, no iteration).

    Parameters
    ----------
    ecef : array_like, shape (..., 3)
        ECEF metres; points closer than about 40 km to the Earth's centre are
        outside the formula's domain.

    Returns
    -------
    lat_deg, lon_deg, height_m : ndarray, each shape (...)
    """
    xyz = np.asarray(ecef, dtype=np.float64)
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    a, b, e2 = WGS84_A, WGS84_B, WGS84_E2
    p = np.hypot(x, y)
    f_ = 54.0 * b**2 * z**2
    g = p**2 + (1.0 - e2) * z**2 - e2 * (a**2 - b**2)
    c = e2**2 * f_ * p**2 / g**3
    s = np.cbrt(1.0 + c + np.sqrt(c**2 + 2.0 * c))
    k = s + 1.0 + 1.0 / s
    big_p = f_ / (3.0 * k**2 * g**2)
    q = np.sqrt(1.0 + 2.0 * e2**2 * big_p)
    r0 = -(big_p * e2 * p) / (1.0 + q) + np.sqrt(
        np.maximum(
            0.5 * a**2 * (1.0 + 1.0 / q) - big_p * (1.0 - e2) * z**2 / (q * (1.0 + q)) - 0.5 * big_p * p**2,
            0.0,
        )
    )
    u = np.hypot(p - e2 * r0, z)
    v = np.sqrt((p - e2 * r0) ** 2 + (1.0 - e2) * z**2)
    z0 = b**2 * z / (a * v)
    height = u * (1.0 - b**2 / (a * v))
    lat = np.arctan2(z + _EP2 * z0, p)
    lon = np.arctan2(y, x)
    return np.degrees(lat), np.degrees(lon), height


@dataclass(frozen=True)
class LocalFrame:
    """A local ENU frame tangent to the WGS84 ellipsoid at a geodetic origin.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Origin latitude and longitude, degrees.
    height_m : float
        Origin height above the ellipsoid, metres.

    Notes
    -----
    With origin latitude phi0 and longitude lambda0 the rows of the rotation
    ECEF -> ENU are the unit vectors east, north and up at the origin:

    .. math::
        R = \\begin{bmatrix}
            -\\sin\\lambda_0 & \\cos\\lambda_0 & 0 \\\\
            -\\sin\\phi_0\\cos\\lambda_0 & -\\sin\\phi_0\\sin\\lambda_0 & \\cos\\phi_0 \\\\
            \\cos\\phi_0\\cos\\lambda_0 & \\cos\\phi_0\\sin\\lambda_0 & \\sin\\phi_0
        \\end{bmatrix},
        \\quad \\mathbf{p}_{enu} = R (\\mathbf{p}_{ecef} - \\mathbf{p}_{0,ecef})
    """

    lat_deg: float
    lon_deg: float
    height_m: float = 0.0
    _origin_ecef: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _rotation: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not (-90.0 <= self.lat_deg <= 90.0) or not np.isfinite(self.lat_deg):
            raise ValueError(f"origin lat_deg must be in [-90, 90], got {self.lat_deg!r}")
        if not (-180.0 <= self.lon_deg <= 180.0) or not np.isfinite(self.lon_deg):
            raise ValueError(f"origin lon_deg must be in [-180, 180], got {self.lon_deg!r}")
        if not np.isfinite(self.height_m):
            raise ValueError(f"origin height_m must be finite, got {self.height_m!r}")
        lat, lon = np.radians(self.lat_deg), np.radians(self.lon_deg)
        sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
        rotation = np.array(
            [
                [-so, co, 0.0],
                [-sl * co, -sl * so, cl],
                [cl * co, cl * so, sl],
            ]
        )
        object.__setattr__(self, "_origin_ecef", geodetic_to_ecef(self.lat_deg, self.lon_deg, self.height_m))
        object.__setattr__(self, "_rotation", rotation)

    def to_enu(self, lat_deg: ArrayLike, lon_deg: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
        """Geodetic (degrees, metres above the ellipsoid) to ENU metres, shape (..., 3)."""
        delta = geodetic_to_ecef(lat_deg, lon_deg, height_m) - self._origin_ecef
        enu: NDArray[np.float64] = delta @ self._rotation.T
        return enu

    def to_enu_each(self, lat_deg: ArrayLike, lon_deg: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
        """:meth:`to_enu` with each point computed by itself, shape (..., 3).

        The rotation is applied with elementwise products and sums instead of a matrix
        product, whose rounding depends on how many points share the call; here a point's
        result is the same bit for bit whatever else is converted with it.
        """
        d = geodetic_to_ecef(lat_deg, lon_deg, height_m) - self._origin_ecef
        r = self._rotation
        return np.stack([r[k, 0] * d[..., 0] + r[k, 1] * d[..., 1] + r[k, 2] * d[..., 2] for k in range(3)], axis=-1)

    def to_geodetic(
        self, enu: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """ENU metres, shape (..., 3), to (lat_deg, lon_deg, height_m)."""
        ecef = np.asarray(enu, dtype=np.float64) @ self._rotation + self._origin_ecef
        return ecef_to_geodetic(ecef)
