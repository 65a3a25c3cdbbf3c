"""One linearisation of the DUIF's update (:func:`gcs.core.filters.iterated.iterated_update`) as a compiled kernel.

The numpy form of eq. (12)-(15) (:mod:`gcs.core.filters.uif`) costs one numpy call, about
a microsecond, for every line of the algorithm on arrays of a few numbers: a step is a
hundred such calls. This module writes the same computation with scalars, element by
element, and compiles it with numba (``njit``, ``cache=False``: nothing is written to
disk) the first time it is used; without numba, :func:`compiled_update` returns None and
the caller runs the numpy form. Both give the same numbers to rounding (a test compares
them).

For the prior ``(x^-, P^-)`` and the point ``(a, P_a)`` the measurement is linearised
about (the prior, then the posterior while it moves; :func:`gcs.core.filters.iterated.iterated_update`),
each detection row, of sensor components ``k`` (range, azimuth, elevation):

* ``L = chol(P_a,pp) = [[l_a, 0], [l_b, l_d]]``; the four sigma points that move the
  position ``a_p +- c L e_j`` (``c = sqrt(n + lambda)``) and the centre are measured
  (eq. 4); ``z^- = Z^0 + W sum_j (Z^j - Z^0)`` with azimuth differences wrapped;
* ``H^p = (1/2c) D^T L^-1``, ``D`` the paired differences ``Z^j - Z^{n+j}`` (eq. 12);
* ``R``: the sensor's variance (zuo2021 eq. 2 when distance-dependent), plus the
  linearisation's second-order variance ``1/2 tr((d^2 H_k P_rel)^2)``
  (:mod:`gcs.core.models.second_order`), plus the vehicle's position error, per-axis
  ``s^2`` (0 when exact): ``s^2, s^2 / rho_h^2, s^2 / rho^2`` (a full covariance ``P_s``
  makes ``R`` full; the numpy form handles it);
* ``i = (H^p)^T R^-1 (nu + H^p a)``, ``I = (H^p)^T R^-1 H^p`` (eq. 13), summed (eq. 14);
* eq. (15) by the inversion lemma, ``P = P^- - P^- E^T A (I_2 + P^-_pp A)^-1 E P^-``,
  ``x = x^- + P E^T (i - A x^-_p)``.

The kernel updates many targets in one call, each with its own rows, and gives each one's
squared Mahalanobis distance from the point it linearised about to the posterior mean,
which decides whether the caller linearises that target again.

Compiling takes a few seconds, once per process, on the first call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["compiled_update", "RANGE_CODE", "AZIMUTH_CODE", "ELEVATION_CODE", "NO_COMPONENT"]

RANGE_CODE, AZIMUTH_CODE, ELEVATION_CODE, NO_COMPONENT = 0, 1, 2, -1
"""Component codes of a detection row (``codes``), padded with ``NO_COMPONENT``."""
MIN_HORIZONTAL_M2 = 1e-6  # as gcs.core.models.second_order
TWO_PI = 2.0 * math.pi


def _wrap(angle: float) -> float:
    """To (-pi, pi], as :func:`gcs.core.geometry.wrap_angle`."""
    return math.pi - (math.pi - angle) % TWO_PI


def _measure(code: int, px: float, py: float, vx: float, vy: float, dz: float) -> float:
    dx, dy = px - vx, py - vy
    horizontal = math.hypot(dx, dy)
    if code == RANGE_CODE:
        return math.hypot(horizontal, dz)
    if code == AZIMUTH_CODE:
        return math.atan2(dy, dx)
    return math.atan2(dz, horizontal)


def _second_order(code: int, dx: float, dy: float, dz: float, pxx: float, pxy: float, pyy: float) -> float:
    """``Omega_k`` of :func:`gcs.core.models.second_order.second_order_variance`, one component."""
    h2 = dx * dx + dy * dy
    if h2 < MIN_HORIZONTAL_M2:
        dx, dy, h2 = 1e-3, 0.0, MIN_HORIZONTAL_M2
    h = math.sqrt(h2)
    ux, uy = dx / h, dy / h
    r2 = h2 + dz * dz
    qx, qy = pxx * ux + pxy * uy, pxy * ux + pyy * uy
    p_uu = qx * ux + qy * uy
    p_uv = qy * ux - qx * uy
    p_vv = pxx + pyy - p_uu
    p_uv2 = p_uv * p_uv
    if code == AZIMUTH_CODE:
        return (p_uv2 + p_uu * p_vv) / (h2 * h2)
    if code == RANGE_CODE:
        r = math.sqrt(r2)
        a, b = dz * dz / (r2 * r), 1.0 / r
    else:
        a, b = 2.0 * dz * h / (r2 * r2), -dz / (r2 * h)
    a_uu, b_vv = a * p_uu, b * p_vv
    return 0.5 * (a_uu * a_uu + b_vv * b_vv) + a * b * p_uv2


def _information(about_mean: NDArray[np.float64], about_cov: NDArray[np.float64], first: int, stop: int,
                 z: NDArray[np.float64], xyz: NDArray[np.float64], codes: NDArray[np.int64], var: NDArray[np.float64],
                 reference_m: NDArray[np.float64], height_m: NDArray[np.float64], vehicle_var: NDArray[np.float64],
                 second_order: bool, c: float, w: float, info: NDArray[np.float64]) -> bool:
    """Summed ``(i, I)`` of rows ``first:stop`` about ``(about_mean, about_cov)`` into ``info`` = [i_x, i_y, I_xx,
    I_xy, I_yy]; False when the position covariance is not positive definite."""
    pxx, pxy, pyy = about_cov[0, 0], about_cov[0, 1], about_cov[1, 1]
    if not pxx > 0.0:
        return False
    la = math.sqrt(pxx)
    lb = pxy / la
    rest = pyy - lb * lb
    if not rest > 0.0:
        return False
    ld = math.sqrt(rest)
    scale = 0.5 / c
    inv00, inv10, inv11 = scale / la, -scale * lb / (la * ld), scale / ld  # (1/2c) L^-1
    ax, ay = about_mean[0], about_mean[1]
    offsets = ((c * la, c * lb), (0.0, c * ld), (-c * la, -c * lb), (0.0, -c * ld))
    h = np.empty((3, 2))
    r, nu, spread = np.empty(3), np.empty(3), np.empty(4)
    for i in range(5):
        info[i] = 0.0
    for row in range(first, stop):
        vx, vy = xyz[row, 0], xyz[row, 1]
        dz = height_m[row] - xyz[row, 2]
        dx, dy = ax - vx, ay - vy
        m = 0
        while m < 3 and codes[row, m] != NO_COMPONENT:
            m += 1
        rel_xx, rel_xy, rel_yy = pxx + vehicle_var[row], pxy, pyy + vehicle_var[row]
        predicted_range = math.sqrt(dx * dx + dy * dy + dz * dz)
        for k in range(m):
            code = codes[row, k]
            centre = _measure(code, ax, ay, vx, vy, dz)
            for j in range(4):
                spread[j] = _measure(code, ax + offsets[j][0], ay + offsets[j][1], vx, vy, dz) - centre
                if code == AZIMUTH_CODE:
                    spread[j] = _wrap(spread[j])
            z_pred = centre + w * spread[0] + w * spread[1] + w * spread[2] + w * spread[3]
            d0, d1 = spread[0] - spread[2], spread[1] - spread[3]
            h[k, 0] = d0 * inv00 + d1 * inv10
            h[k, 1] = d1 * inv11
            residual = z[row, k] - z_pred
            if code == AZIMUTH_CODE:
                residual = _wrap(residual)
            nu[k] = residual + h[k, 0] * ax + h[k, 1] * ay
            if k == 0 and code == RANGE_CODE:
                predicted_range = z_pred  # distance-dependent noise is taken at the range's z^-
            r[k] = var[row, k]
            if reference_m[row] > 0.0:  # distance-dependent noise (zuo2021 eq. 2)
                growth = max(predicted_range / reference_m[row], 1.0)
                r[k] *= growth * growth
            if second_order:
                r[k] += _second_order(code, dx, dy, dz, rel_xx, rel_xy, rel_yy)
            s2 = vehicle_var[row]  # the vehicle's per-axis error, isotropic (0 when exact)
            h2 = max(dx * dx + dy * dy, MIN_HORIZONTAL_M2)
            if code == AZIMUTH_CODE:
                s2 = s2 / h2
            elif code == ELEVATION_CODE:
                s2 = s2 / (h2 + dz * dz)
            r[k] += s2
        for k in range(m):  # R diagonal: (H^p)^T R^-1 column by column
            scale_k = 1.0 / math.sqrt(r[k])
            hx, hy, nk = h[k, 0] * scale_k, h[k, 1] * scale_k, nu[k] * scale_k
            info[0] += hx * nk
            info[1] += hy * nk
            info[2] += hx * hx
            info[3] += hx * hy
            info[4] += hy * hy
    return True


def _fuse(mean: NDArray[np.float64], cov: NDArray[np.float64], info: NDArray[np.float64],
          out_mean: NDArray[np.float64], out_cov: NDArray[np.float64]) -> None:
    """Eq. (14)-(15) by the inversion lemma (:meth:`gcs.core.filters.uif.UnscentedInformationFilter.update`)."""
    n = mean.shape[0]
    a00, a01, a11 = info[2], info[3], info[4]
    m00 = 1.0 + cov[0, 0] * a00 + cov[0, 1] * a01
    m01 = cov[0, 0] * a01 + cov[0, 1] * a11
    m10 = cov[1, 0] * a00 + cov[1, 1] * a01
    m11 = 1.0 + cov[1, 0] * a01 + cov[1, 1] * a11
    det = m00 * m11 - m01 * m10
    i00, i01, i10, i11 = m11 / det, -m01 / det, -m10 / det, m00 / det
    k00, k01 = a00 * i00 + a01 * i10, a00 * i01 + a01 * i11  # A (I + P_pp A)^-1
    k10, k11 = a01 * i00 + a11 * i10, a01 * i01 + a11 * i11
    for r in range(n):
        g0 = cov[r, 0] * k00 + cov[r, 1] * k10
        g1 = cov[r, 0] * k01 + cov[r, 1] * k11
        for s in range(n):
            out_cov[r, s] = cov[r, s] - (g0 * cov[s, 0] + g1 * cov[s, 1])
    for r in range(n):
        for s in range(r + 1, n):
            symmetric = 0.5 * (out_cov[r, s] + out_cov[s, r])
            out_cov[r, s] = symmetric
            out_cov[s, r] = symmetric
    bx = info[0] - (a00 * mean[0] + a01 * mean[1])
    by = info[1] - (a01 * mean[0] + a11 * mean[1])
    for r in range(n):
        out_mean[r] = mean[r] + out_cov[r, 0] * bx + out_cov[r, 1] * by


def _linearised_updates(means: NDArray[np.float64], covs: NDArray[np.float64], about_means: NDArray[np.float64],
                        about_covs: NDArray[np.float64], active: NDArray[np.bool_], starts: NDArray[np.int64],
                        z: NDArray[np.float64], xyz: NDArray[np.float64], codes: NDArray[np.int64],
                        var: NDArray[np.float64], reference_m: NDArray[np.float64], height_m: NDArray[np.float64],
                        vehicle_var: NDArray[np.float64], second_order: bool, c: float, w: float,
                        out_means: NDArray[np.float64], out_covs: NDArray[np.float64],
                        moved: NDArray[np.float64]) -> None:
    """One update of each active target ``t`` (priors ``means`` (T, n), ``covs`` (T, n, n)) with its rows
    ``starts[t]:starts[t + 1]``, linearised about ``(about_means[t], about_covs[t])``, into ``out_means[t]``,
    ``out_covs[t]``; ``moved[t]`` is the squared Mahalanobis distance (position, posterior covariance) from the
    point it was linearised about to the posterior mean, or -1 when a covariance lost definiteness."""
    info = np.empty(5)
    for t in range(means.shape[0]):
        if not active[t]:
            continue
        if not _information(about_means[t], about_covs[t], starts[t], starts[t + 1], z, xyz, codes, var,
                            reference_m, height_m, vehicle_var, second_order, c, w, info):
            moved[t] = -1.0
            continue
        _fuse(means[t], covs[t], info, out_means[t], out_covs[t])
        mx, my = out_means[t, 0] - about_means[t, 0], out_means[t, 1] - about_means[t, 1]
        cxx, cxy, cyy = out_covs[t, 0, 0], out_covs[t, 0, 1], out_covs[t, 1, 1]
        det = cxx * cyy - cxy * cxy
        moved[t] = (cyy * mx * mx - 2.0 * cxy * mx * my + cxx * my * my) / det if det > 0.0 else -1.0


Kernel = Callable[..., None]


@lru_cache(maxsize=1)
def compiled_update() -> Kernel | None:
    """The compiled :func:`_linearised_updates` (compiled on its first call, in memory only), or None without
    numba."""
    try:
        import numba
    except ImportError:
        return None
    compiler: Any = numba.njit(cache=False, nogil=True, error_model="numpy")
    global _wrap, _measure, _second_order, _information, _fuse  # the compiled callees, found when compiling
    _wrap, _measure, _second_order = compiler(_wrap), compiler(_measure), compiler(_second_order)
    _information, _fuse = compiler(_information), compiler(_fuse)
    kernel: Kernel = compiler(_linearised_updates)
    return kernel
