"""The variance a linearised range / azimuth / elevation measurement (wang2012 eq. 4) leaves out.

A filter that linearises ``H`` about the predicted position ``p`` (the EKF's Jacobian or
the UIF's statistical ``H^p``) drops the second-order term ``1/2 e^T (d^2 H_k) e`` of the
position error ``e ~ N(0, P)``, whose variance is (the second-order filter's term;
Bar-Shalom, Li & Kirubarajan 2001, ch. 10)

.. math::
    \\Omega_k = \\tfrac12 \\operatorname{tr}\\big((\\nabla^2 H_k \\, P)^2\\big).

With ``u`` the unit horizontal line of sight and ``v`` its left normal, the Hessians with
respect to the target's (x, y) are

.. math::
    \\nabla^2 \\rho = \\frac{1}{\\rho}\\Big(\\frac{dz^2}{\\rho^2} u u^T + v v^T\\Big), \\quad
    \\nabla^2 \\varphi = -\\frac{u v^T + v u^T}{\\rho_h^2}, \\quad
    \\nabla^2 \\theta = \\frac{2\\, dz\\, \\rho_h}{\\rho^4} u u^T - \\frac{dz}{\\rho^2 \\rho_h} v v^T.

Far from the target these are negligible against ``R``; under the vehicle they are not:
the azimuth's term grows as ``|P|^2 / rho_h^4`` and, once the uncertainty reaches
``rho_h``, the azimuth stops being informative at all (its sigma points straddle the
vehicle), which the term says by dwarfing ``sigma_phi^2``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.components import AZIMUTH, RANGE

__all__ = ["MIN_HORIZONTAL_M2", "off_the_vertical", "second_order_variance"]

MIN_HORIZONTAL_M2 = 1e-6
"""Floor of ``rho_h^2`` (a vehicle right above the target)."""


def off_the_vertical(dx: NDArray[np.float64], dy: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(dx, dy, rho_h^2)`` with ``rho_h^2`` at least :data:`MIN_HORIZONTAL_M2`: straight above the target there
    is no horizontal line of sight to speak of, and any direction will do (the target is moved to 1 mm east,
    so that ``(dx, dy) / rho_h`` stays a unit vector)."""
    h2 = dx * dx + dy * dy
    straight_below = h2 < MIN_HORIZONTAL_M2
    if np.any(straight_below):
        dx = np.where(straight_below, 1e-3, dx)
        dy = np.where(straight_below, 0.0, dy)
        h2 = np.where(straight_below, MIN_HORIZONTAL_M2, h2)
    return dx, dy, h2


def second_order_variance(components: Sequence[str], dx: NDArray[np.float64], dy: NDArray[np.float64],
                          dz: NDArray[np.float64], position_cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """``Omega_k`` (..., m) of each of ``components`` (module docstring).

    ``dx, dy, dz`` (...): the target's position relative to the vehicle; ``position_cov``
    (..., 2, 2): the covariance of that relative horizontal position.
    """
    dx, dy, h2 = off_the_vertical(dx, dy)
    h = np.sqrt(h2)
    ux, uy = dx / h, dy / h
    r2 = h2 + dz * dz
    # P in the (u, v) frame, v = (-uy, ux): p_uu = u^T P u, p_uv = u^T P v, p_vv = tr P - p_uu.
    pxx, pxy, pyy = position_cov[..., 0, 0], position_cov[..., 0, 1], position_cov[..., 1, 1]
    qx, qy = pxx * ux + pxy * uy, pxy * ux + pyy * uy  # P u
    p_uu = qx * ux + qy * uy
    p_uv = qy * ux - qx * uy
    p_vv = pxx + pyy - p_uu
    p_uv2 = p_uv * p_uv
    out = np.empty(np.broadcast(h2, pxx).shape + (len(components),))
    for k, component in enumerate(components):
        if component == AZIMUTH:  # [[0, c], [c, 0]]: 1/2 tr((A P)^2) = c^2 (p_uv^2 + p_uu p_vv)
            out[..., k] = (p_uv2 + p_uu * p_vv) / (h2 * h2)
            continue
        if component == RANGE:
            r = np.sqrt(r2)
            a, b = dz * dz / (r2 * r), 1.0 / r
        else:
            a, b = 2.0 * dz * h / (r2 * r2), -dz / (r2 * h)
        # [[a, 0], [0, b]]: 1/2 tr((A P)^2) = 1/2 (a^2 p_uu^2 + 2 a b p_uv^2 + b^2 p_vv^2)
        a_uu, b_vv = a * p_uu, b * p_vv
        out[..., k] = 0.5 * (a_uu * a_uu + b_vv * b_vv) + a * b * p_uv2
    return out
