"""Which (track, detection) pairs can pass the chi-square gate, found without evaluating every pair.

The gate (:mod:`gcs.core.multitarget.gating`) validates detection ``j`` for track ``t``
when ``d^2 = nu^T S^-1 nu <= gamma``. For any component, here the azimuth ``a``,
Cauchy-Schwarz gives ``nu_a^2 <= (nu^T S^-1 nu) S_aa``, so a pair passes only if

.. math::
    |\\nu_a| \\le \\sqrt{\\gamma \\, S_{aa}}, \\qquad
    S_{aa} = \\frac{v^T P_{pp} v}{\\rho_h^2} + \\sigma_\\varphi^2 + \\frac{\\lambda_s}{\\rho_h^2}

with ``v`` the unit normal to the horizontal line of sight, ``rho_h`` its length,
``sigma_phi^2`` the azimuth's noise (at the predicted range when distance-dependent) and
``lambda_s`` a bound on the vehicle position error's variance across the line of sight
(the trace of its horizontal block, the largest in the batch). The bound is exact for a
pair's own ``S`` and conservative across the batch, so no pair that would pass the gate
is left out (a test compares with the full evaluation).

A batch is one vehicle's detections, taken from one position: for each distinct
position the tracks' azimuths and windows are computed once (T of them), the
detections' azimuths sorted once, and each track's window found by bisection
(``searchsorted`` on the azimuths repeated at -2 pi, 0, +2 pi, so that a window
across the +-pi seam is one interval). The work is ``O((T + n) log n)`` plus the pairs
found, not ``O(T n)``: a track's cost does not grow with tracks elsewhere.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.second_order import off_the_vertical
from gcs.core.models.sensor import SensorModel

__all__ = ["candidate_pairs", "WINDOW_MARGIN"]

WINDOW_MARGIN = 1.0 + 1e-6
"""The windows are widened by this factor, so that rounding cannot drop a pair on the gate's edge."""


def candidate_pairs(mean: NDArray[np.float64], cov: NDArray[np.float64], sensor: SensorModel, z: NDArray[np.float64],
                    xyz: NDArray[np.float64], pcov: NDArray[np.float64], gamma: float
                    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Track and detection indices ``(rows, cols)`` of every pair whose azimuth can pass a gate of ``gamma``.

    Shapes as :func:`gcs.core.multitarget.filter.innovations`: ``mean`` (T, 4), ``cov``
    (T, 4, 4), ``z`` (n, m), ``xyz`` (n, 3), ``pcov`` (n, 3, 3). Pairs come out ordered by
    vehicle position, then track, then azimuth.
    """
    t_count, n_count = mean.shape[0], z.shape[0]
    if t_count == 0 or n_count == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    positions, where = np.unique(xyz, axis=0, return_inverse=True)
    where = where.reshape(-1)
    rows, cols = [], []
    for u in range(positions.shape[0]):
        members = np.flatnonzero(where == u)
        r, c = _pairs_from(mean, cov, sensor, z[members, sensor.azimuth_index], positions[u],
                           float(np.max(np.trace(pcov[members, :2, :2], axis1=1, axis2=2))), gamma)
        rows.append(r)
        cols.append(members[c])
    return np.concatenate(rows), np.concatenate(cols)


def _pairs_from(mean: NDArray[np.float64], cov: NDArray[np.float64], sensor: SensorModel,
                azimuths: NDArray[np.float64], position: NDArray[np.float64], across_var: float, gamma: float
                ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The pairs of every track with the detections (azimuths (k,)) taken from one ``position`` (3,)."""
    k = azimuths.shape[0]
    dx, dy, h2 = off_the_vertical(mean[:, 0] - position[0], mean[:, 1] - position[1])
    bearing = np.arctan2(dy, dx)
    pxx, pxy, pyy = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    across = (pxx * dy * dy - 2.0 * pxy * dx * dy + pyy * dx * dx) / h2  # v^T P v, v = (-dy, dx) / rho_h
    noise = np.broadcast_to(sensor.noise_variance(sensor.measure(mean[:, :2], position), mean[:, :2], position),
                            (mean.shape[0], sensor.dim))[:, sensor.azimuth_index]
    half_width = WINDOW_MARGIN * np.sqrt(gamma * ((across + across_var) / h2 + noise))
    order = np.argsort(azimuths, kind="stable")
    ring = np.concatenate([azimuths[order] - 2.0 * np.pi, azimuths[order], azimuths[order] + 2.0 * np.pi])
    everything = ~(half_width < np.pi)  # a window of the whole circle (NaN included): every detection
    low = np.searchsorted(ring, np.where(everything, -np.pi, bearing - half_width), side="left")
    high = np.searchsorted(ring, np.where(everything, -np.pi, bearing + half_width), side="right")
    low = np.where(everything, k, low)
    high = np.where(everything, 2 * k, high)
    counts = high - low
    rows = np.repeat(np.arange(mean.shape[0]), counts)
    starts = np.repeat(low - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return rows, order[(starts + np.arange(rows.shape[0])) % k]
