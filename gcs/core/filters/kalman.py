"""The linear(ised) Kalman measurement update, with its likelihood, for the switching filters.

For a prior ``N(x^-, P^-)`` and an observation ``z = H x + w``, ``w ~ N(0, R)``
(or the first-order expansion of a nonlinear ``h`` about ``x^-``, with the
innovation ``nu = z - h(x^-)`` supplied by the caller):

.. math::
    S = H P^- H^T + R, \\quad K = P^- H^T S^{-1}, \\quad x = x^- + K \\nu,

    P = (I - K H) P^- (I - K H)^T + K R K^T   \\quad \\text{(Joseph form)},

    \\log l = -\\tfrac12 \\big(\\nu^T S^{-1} \\nu + \\log\\det(2 \\pi S)\\big)

``l`` is the likelihood ``N(nu; 0, S)`` of the observation under the filter's
model: the ``l_t^j`` of Murphy's switching filter (feng2019 section 2), which
weighs the modes against each other. Angle components of ``nu`` must be wrapped
by the caller (:class:`Observation` does it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from gcs.core.geometry import wrap_angle

__all__ = ["Observation", "kalman_update", "stack_observations"]

_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class Observation:
    """A linear observation ``z = H x + w``, ``w ~ N(0, R)``.

    Attributes
    ----------
    z : ndarray, shape (m,)
    h : ndarray, shape (m, n)
    r : ndarray, shape (m, m)
        Symmetric positive definite.
    angle_rows : tuple of int
        Rows of ``z`` that are angles: their innovation is wrapped to (-pi, pi].
    """

    z: NDArray[np.float64]
    h: NDArray[np.float64]
    r: NDArray[np.float64]
    angle_rows: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        m = self.z.shape[0]
        assert self.z.shape == (m,), f"z must be (m,), got {self.z.shape}"
        assert self.h.ndim == 2 and self.h.shape[0] == m, f"h must be ({m}, n), got {self.h.shape}"
        assert self.r.shape == (m, m), f"r must be ({m}, {m}), got {self.r.shape}"
        assert all(0 <= row < m for row in self.angle_rows), f"angle rows {self.angle_rows} outside 0..{m - 1}"

    def innovation(self, mean: NDArray[np.float64]) -> NDArray[np.float64]:
        """``nu = z - H x`` with the angle rows wrapped."""
        nu = self.z - self.h @ mean
        for row in self.angle_rows:
            nu[row] = wrap_angle(nu[row])
        return nu


def stack_observations(observations: Sequence[Observation]) -> Observation | None:
    """One observation of every component (block-diagonal ``R``: independent errors); None if empty.

    For a linear model the stacked update equals the sequential one.
    """
    if not observations:
        return None
    if len(observations) == 1:
        return observations[0]
    sizes = [o.z.shape[0] for o in observations]
    r = np.zeros((sum(sizes), sum(sizes)))
    angle_rows = []
    offset = 0
    for o, m in zip(observations, sizes):
        r[offset:offset + m, offset:offset + m] = o.r
        angle_rows += [offset + row for row in o.angle_rows]
        offset += m
    return Observation(np.concatenate([o.z for o in observations]), np.vstack([o.h for o in observations]), r,
                       tuple(angle_rows))


def kalman_update(mean: NDArray[np.float64], cov: NDArray[np.float64],
                  observation: Observation) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Posterior mean (n,), covariance (n, n) and log-likelihood of ``observation`` (module docstring)."""
    h, r = observation.h, observation.r
    nu = observation.innovation(mean)
    ph_t = cov @ h.T
    s = h @ ph_t + r
    factor, info = lapack.dpotrf(s, lower=1, clean=1)  # S = L L^T
    if info != 0:
        raise np.linalg.LinAlgError(f"innovation covariance is not positive definite (dpotrf info={info})")
    solved, _ = lapack.dpotrs(factor, np.column_stack([ph_t.T, nu]), lower=1)  # S^-1 [H P, nu]
    gain = solved[:, :-1].T
    i_kh = np.eye(mean.shape[0]) - gain @ h
    post = i_kh @ cov @ i_kh.T + gain @ r @ gain.T
    log_det = 2.0 * float(np.sum(np.log(np.diag(factor))))
    log_lik = -0.5 * (float(nu @ solved[:, -1]) + log_det + nu.shape[0] * _LOG_2PI)
    return mean + gain @ nu, 0.5 * (post + post.T), log_lik
