"""Switching Kalman filter machinery (Murphy 1998/2002, as used by feng2019 section 2): modes, collapse.

A switching linear dynamic system has a discrete mode ``S_t`` (a Markov chain)
and a continuous state ``X_t`` whose dynamics or observation depend on it
(feng2019 eq. 6 with ``A, C, Q, R`` indexed by the mode). The exact posterior
is a mixture of ``N^t`` Gaussians; the filters here keep ``N``, one per mode.

Index conventions (asserted by :func:`check_transition`)
--------------------------------------------------------
* Modes are numbered ``0..N-1``; ``probabilities[j] = P(S_t = j | y_{1:t})``.
* The transition matrix is **row-stochastic**: ``C[i, j] = P(S_t = j | S_{t-1} = i)``
  (feng2019: ``c_ij = p(S_t = j / S_{t-1} = i)``), every row sums to one. It may be
  rectangular, ``(N_prev, N_new)``, when the set of modes changes between steps
  (the navigation filter's candidate route segments).
* ``means`` is (N, n), ``covs`` is (N, n, n): row ``j`` is the Gaussian of mode ``j``.

Collapse by moment matching (feng2019, last two equations of section 2)
----------------------------------------------------------------------
.. math::
    \\hat x = \\sum_j w_j x_j, \\qquad
    \\hat V = \\sum_j w_j \\big(V_j + (x_j - \\hat x)(x_j - \\hat x)^T\\big)

the single Gaussian of least Kullback-Leibler divergence from the mixture. Angle
components (``angle_indices``) are averaged as wrapped deviations from the
heaviest component's value, and the result is wrapped, so headings either side of
+-pi collapse correctly.

GPB2, the paper's algorithm (Murphy's "filter" and "collapse" steps)
-------------------------------------------------------------------
For every pair ``(i, j)``: ``[x^{ij}, V^{ij}, l^{ij}] = filter(x^i_{t-1}, V^i_{t-1}, y_t, model j)``;

.. math::
    M(i, j) = \\frac{l^{ij} c_{ij} w^i_{t-1}}{\\sum_{ij} l^{ij} c_{ij} w^i_{t-1}}, \\quad
    w^j_t = \\sum_i M(i, j), \\quad g^{ij} = M(i, j) / w^j_t, \\quad
    [x^j_t, V^j_t] = \\text{collapse}(\\{x^{ij}, V^{ij}, g^{ij}\\}_i)

IMM (Blom and Bar-Shalom 1988), the cheaper alternative with N filters instead of
``N^2``: mix first, ``mu_{i|j} = c_ij w^i / cbar_j`` with ``cbar_j = sum_i c_ij w^i``,
filter each mode once from its mixed prior, then ``w^j_t \\propto l^j cbar_j``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from gcs.core.geometry import wrap_angle

__all__ = ["ModeMixture", "check_transition", "collapse", "gpb2_step", "imm_step", "PairFilter", "ModeFilter"]

STOCHASTIC_ATOL = 1e-9
"""Tolerance on the row sums of a transition matrix and the sum of mode probabilities."""

PairFilter = Callable[[int, int, NDArray[np.float64], NDArray[np.float64]],
                      tuple[NDArray[np.float64], NDArray[np.float64], float]]
"""``filter(i, j, mean_i, cov_i) -> (mean, cov, log_likelihood)``: from mode i's posterior at t-1,
the model of mode j at t (prediction and update)."""
ModeFilter = Callable[[int, NDArray[np.float64], NDArray[np.float64]],
                      tuple[NDArray[np.float64], NDArray[np.float64], float]]
"""``filter(j, mean, cov) -> (mean, cov, log_likelihood)``: mode j's model from a mixed prior."""


def check_transition(matrix: NDArray[np.float64], n_from: int, n_to: int) -> NDArray[np.float64]:
    """Assert that ``matrix`` is a row-stochastic (n_from, n_to) matrix: ``C[i, j] = P(next = j | now = i)``."""
    c = np.asarray(matrix, dtype=np.float64)
    assert c.shape == (n_from, n_to), f"transition matrix must be ({n_from}, {n_to}), got {c.shape}"
    assert np.all(np.isfinite(c)) and np.all(c >= 0.0), "transition probabilities must be finite and >= 0"
    sums = c.sum(axis=1)
    assert np.allclose(sums, 1.0, atol=STOCHASTIC_ATOL), f"rows must sum to 1 (row-stochastic), got {sums}"
    return c


def _check_weights(weights: NDArray[np.float64]) -> None:
    assert weights.ndim == 1 and weights.size >= 1, f"weights must be (K,), got {weights.shape}"
    assert np.all(weights >= 0.0) and abs(weights.sum() - 1.0) <= 1e-6, f"weights must be >= 0 and sum to 1, got {weights}"


def collapse(weights: NDArray[np.float64], means: NDArray[np.float64], covs: NDArray[np.float64],
             angle_indices: Sequence[int] = ()) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Moment-matched Gaussian (n,), (n, n) of the mixture ``sum_k w_k N(means[k], covs[k])``.

    ``weights`` (K,) are non-negative and sum to one; see the module docstring for angles.
    """
    w = np.asarray(weights, dtype=np.float64)
    _check_weights(w)
    k, n = means.shape
    assert w.shape == (k,) and covs.shape == (k, n, n), f"shapes {w.shape}, {means.shape}, {covs.shape} disagree"
    reference = means[int(np.argmax(w))]
    deviation = means - reference
    for a in angle_indices:
        deviation[:, a] = wrap_angle(deviation[:, a])
    shift = w @ deviation
    centred = deviation - shift
    cov = np.einsum("k,kij->ij", w, covs) + (centred.T * w) @ centred
    mean = reference + shift
    for a in angle_indices:
        mean[a] = wrap_angle(mean[a])
    return mean, 0.5 * (cov + cov.T)


@dataclass(frozen=True)
class ModeMixture:
    """Mode probabilities (N,), and the Gaussian of each mode: means (N, n), covariances (N, n, n)."""

    probabilities: NDArray[np.float64]
    means: NDArray[np.float64]
    covs: NDArray[np.float64]

    def __post_init__(self) -> None:
        n_modes, n = self.means.shape
        assert self.probabilities.shape == (n_modes,), f"probabilities must be ({n_modes},)"
        assert self.covs.shape == (n_modes, n, n), f"covs must be ({n_modes}, {n}, {n}), got {self.covs.shape}"
        _check_weights(self.probabilities)

    @property
    def modes(self) -> int:
        """Number of modes N."""
        return len(self.probabilities)

    def collapse(self, angle_indices: Sequence[int] = ()) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The moment-matched Gaussian of the whole mixture."""
        return collapse(self.probabilities, self.means, self.covs, angle_indices)


def _normalise_log(log_weights: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    """``exp(log_w) / sum`` computed from the largest term; ``fallback`` when every weight is zero."""
    top = float(np.max(log_weights))
    weights = fallback if not np.isfinite(top) else np.exp(log_weights - top)
    normalised: NDArray[np.float64] = weights / weights.sum()
    return normalised


def _safe_log(x: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(divide="ignore"):
        return np.log(x)


def gpb2_step(prior: ModeMixture, transition: NDArray[np.float64], filter_pair: PairFilter,
              angle_indices: Sequence[int] = ()) -> tuple[ModeMixture, NDArray[np.float64]]:
    """One GPB2 step (module docstring) from ``prior`` (N_prev modes) to N_new modes.

    Returns the new mixture and the joint ``M(i, j) = P(S_{t-1} = i, S_t = j | y_{1:t})``.
    Pairs with ``c_ij w^i = 0`` are not filtered. A new mode that no pair reaches
    keeps weight zero and the collapse of its pairs by the prior weights.
    """
    n_prev, n_new = prior.modes, transition.shape[1]
    c = check_transition(transition, n_prev, n_new)
    dim = prior.means.shape[1]
    prior_joint = prior.probabilities[:, None] * c  # c_ij w^i
    log_joint = np.full((n_prev, n_new), -np.inf)
    means = np.zeros((n_prev, n_new, dim))
    covs = np.zeros((n_prev, n_new, dim, dim))
    for j in range(n_new):
        for i in range(n_prev):
            if prior_joint[i, j] > 0.0 or not prior_joint[:, j].any():
                means[i, j], covs[i, j], log_lik = filter_pair(i, j, prior.means[i], prior.covs[i])
                if prior_joint[i, j] > 0.0:
                    log_joint[i, j] = log_lik + np.log(prior_joint[i, j])
    joint = _normalise_log(log_joint.ravel(), prior_joint.ravel()).reshape(n_prev, n_new)
    weights = joint.sum(axis=0)
    new_means = np.empty((n_new, dim))
    new_covs = np.empty((n_new, dim, dim))
    for j in range(n_new):
        g = joint[:, j] / weights[j] if weights[j] > 0.0 else _fallback_column(prior_joint[:, j], prior.probabilities)
        new_means[j], new_covs[j] = collapse(g, means[:, j], covs[:, j], angle_indices)
    return ModeMixture(weights / weights.sum(), new_means, new_covs), joint


def _fallback_column(column: NDArray[np.float64], prior: NDArray[np.float64]) -> NDArray[np.float64]:
    weights = column if column.sum() > 0.0 else prior
    normalised: NDArray[np.float64] = weights / weights.sum()
    return normalised


def imm_step(prior: ModeMixture, transition: NDArray[np.float64], filter_mode: ModeFilter,
             angle_indices: Sequence[int] = ()) -> ModeMixture:
    """One IMM step (module docstring): mix, filter each of the N_new modes once, reweigh."""
    n_prev, n_new = prior.modes, transition.shape[1]
    c = check_transition(transition, n_prev, n_new)
    dim = prior.means.shape[1]
    prior_joint = prior.probabilities[:, None] * c
    c_bar = prior_joint.sum(axis=0)  # predicted mode probabilities
    log_w = np.full(n_new, -np.inf)
    means = np.empty((n_new, dim))
    covs = np.empty((n_new, dim, dim))
    for j in range(n_new):
        mixing = _fallback_column(prior_joint[:, j], prior.probabilities)  # mu_{i|j}
        mixed_mean, mixed_cov = collapse(mixing, prior.means, prior.covs, angle_indices)
        means[j], covs[j], log_lik = filter_mode(j, mixed_mean, mixed_cov)
        log_w[j] = log_lik + _safe_log(c_bar[j])
    return ModeMixture(_normalise_log(log_w, c_bar if c_bar.sum() > 0 else np.ones(n_new)), means, covs)
