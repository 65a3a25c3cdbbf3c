"""Sigma points and weights of the scaled unscented transform (van der Merwe 2004).

For a state of dimension n with ``lambda = alpha^2 (n + kappa) - n``:

.. math::
    \\chi_0 = \\hat x, \\quad
    \\chi_j = \\hat x + \\big(\\sqrt{(n + \\lambda) P}\\big)_j, \\quad
    \\chi_{n+j} = \\hat x - \\big(\\sqrt{(n + \\lambda) P}\\big)_j, \\quad j = 1..n

.. math::
    W_m^0 = \\frac{\\lambda}{n + \\lambda}, \\quad
    W_c^0 = W_m^0 + 1 - \\alpha^2 + \\beta, \\quad
    W_m^j = W_c^j = \\frac{1}{2 (n + \\lambda)}

These are the ``chi^j`` and ``W_m^j`` of wang2012 eq. (11) and (16). The matrix
square root is the lower Cholesky factor (columns ``L[:, j]``), as in FilterPy's
``MerweScaledSigmaPoints`` but batched over leading axes.

Defaults: ``alpha = 1, beta = 2, kappa = 3 - n`` (Julier's choice, which matches
the fourth moment of a Gaussian; ``kappa`` is computed from n when left ``None``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["SigmaPointParameters"]


@lru_cache(maxsize=32)
def _weights(n: int, alpha: float, beta: float, kappa: float) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    lam = alpha**2 * (n + kappa) - n
    wm = np.full(2 * n + 1, 1.0 / (2.0 * (n + lam)))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = wm[0] + 1.0 - alpha**2 + beta
    wm.flags.writeable = False
    wc.flags.writeable = False
    return wm, wc, lam


@dataclass(frozen=True)
class SigmaPointParameters:
    """Scaled unscented transform parameters; ``kappa=None`` means ``3 - n``."""

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float | None = None

    def weights(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """``(W_m, W_c, lambda)`` for dimension n; weights have shape (2n + 1,)."""
        kappa = 3.0 - n if self.kappa is None else self.kappa
        return _weights(n, float(self.alpha), float(self.beta), float(kappa))

    def points(self, mean: NDArray[np.float64], cov: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sigma points of N(mean, cov), shape (..., 2n + 1, n), batched over leading axes."""
        n = mean.shape[-1]
        _, _, lam = self.weights(n)
        scaled = np.linalg.cholesky((n + lam) * cov)  # (..., n, n), columns are the offsets
        offsets = np.swapaxes(scaled, -1, -2)  # (..., n, n), rows are the offsets
        centre = mean[..., None, :]
        return np.concatenate([centre, centre + offsets, centre - offsets], axis=-2)
