"""Switching Kalman filter machinery (feng2019 section 2, Murphy's GPB2; IMM) against independent oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter

from gcs.core.filters.kalman import Observation, kalman_update, stack_observations
from gcs.core.filters.switching import ModeMixture, check_transition, collapse, gpb2_step, imm_step

F = np.array([[1.0, 1.0], [0.0, 1.0]])
H = np.array([[1.0, 0.0]])


def _q(psd: float) -> np.ndarray:
    return psd * np.array([[1.0 / 3.0, 0.5], [0.5, 1.0]])


def _linear_pair_filter(qs, rs, z):
    """filter(i, j): predict with mode j's Q, update with mode j's R (the modes' models)."""
    def run(i, j, mean, cov):
        m, p = F @ mean, F @ cov @ F.T + qs[j]
        return kalman_update(m, p, Observation(np.atleast_1d(z), H, np.array([[rs[j]]])))
    return run


def test_collapse_preserves_the_mixture_mean_and_covariance() -> None:
    rng = np.random.default_rng(1)
    w = rng.dirichlet(np.ones(4))
    means = rng.normal(size=(4, 3)) * 5.0
    roots = rng.normal(size=(4, 3, 3))
    covs = roots @ roots.swapaxes(1, 2) + np.eye(3)
    mean, cov = collapse(w, means, covs)
    # Second moments of the mixture, computed the other way round: E[x x^T] - E[x] E[x]^T.
    first = np.einsum("k,ki->i", w, means)
    second = np.einsum("k,kij->ij", w, covs + np.einsum("ki,kj->kij", means, means))
    np.testing.assert_allclose(mean, first, rtol=1e-12)
    np.testing.assert_allclose(cov, second - np.outer(first, first), rtol=1e-10, atol=1e-10)
    samples = np.concatenate([rng.multivariate_normal(means[k], covs[k], size=int(200_000 * w[k]) + 1) for k in range(4)])
    np.testing.assert_allclose(np.cov(samples.T), cov, rtol=0.05, atol=0.3)  # and against sampling


def test_collapse_wraps_angles_across_the_seam() -> None:
    w = np.array([0.5, 0.5])
    means = np.array([[0.0, math.pi - 0.1], [10.0, -math.pi + 0.1]])
    covs = np.stack([np.eye(2) * 0.01] * 2)
    mean, cov = collapse(w, means, covs, angle_indices=(1,))
    assert mean[0] == pytest.approx(5.0)
    assert abs(abs(mean[1]) - math.pi) < 1e-12  # pi, not 0
    assert cov[1, 1] == pytest.approx(0.01 + 0.01)  # spread of +-0.1 rad, not +-(pi - 0.1)


def test_transition_matrices_must_be_row_stochastic() -> None:
    check_transition(np.array([[0.9, 0.1], [0.3, 0.7]]), 2, 2)
    check_transition(np.array([[0.2, 0.3, 0.5]]), 1, 3)  # rectangular: the mode set changed
    with pytest.raises(AssertionError, match="row-stochastic"):
        check_transition(np.array([[0.9, 0.3], [0.1, 0.7]]), 2, 2)  # column-stochastic
    with pytest.raises(AssertionError, match=r"\(2, 3\)"):
        check_transition(np.eye(2), 2, 3)
    with pytest.raises(AssertionError, match=">= 0"):
        check_transition(np.array([[1.5, -0.5], [0.0, 1.0]]), 2, 2)
    prior = ModeMixture(np.array([0.5, 0.5]), np.zeros((2, 2)), np.stack([np.eye(2)] * 2))
    with pytest.raises(AssertionError):
        gpb2_step(prior, np.array([[0.9, 0.3], [0.1, 0.7]]), _linear_pair_filter([_q(1)] * 2, [1, 1], 0.0))


def test_kalman_update_equals_filterpy_and_stacking_equals_sequential_updates() -> None:
    rng = np.random.default_rng(2)
    root = rng.normal(size=(4, 4))
    prior_cov = root @ root.T + np.eye(4)
    prior_mean = rng.normal(size=4)
    h1, h2 = rng.normal(size=(2, 4)), rng.normal(size=(1, 4))
    o1 = Observation(rng.normal(size=2), h1, np.diag([0.5, 2.0]))
    o2 = Observation(rng.normal(size=1), h2, np.array([[0.3]]))
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.x, kf.P, kf.H, kf.R = prior_mean.copy(), prior_cov.copy(), h1, o1.r
    kf.update(o1.z)
    mean, cov, log_lik = kalman_update(prior_mean, prior_cov, o1)
    np.testing.assert_allclose(mean, kf.x, rtol=1e-10)
    np.testing.assert_allclose(cov, kf.P, rtol=1e-10, atol=1e-12)
    assert log_lik == pytest.approx(kf.log_likelihood, rel=1e-10)
    m2, c2, l2 = kalman_update(mean, cov, o2)
    ms, cs, ls = kalman_update(prior_mean, prior_cov, stack_observations([o1, o2]))
    np.testing.assert_allclose(ms, m2, rtol=1e-9)
    np.testing.assert_allclose(cs, c2, rtol=1e-9, atol=1e-12)
    assert ls == pytest.approx(log_lik + l2, rel=1e-10)  # p(z1, z2) = p(z1) p(z2 | z1)


def test_one_mode_gpb2_and_imm_are_the_plain_kalman_filter() -> None:
    rng = np.random.default_rng(3)
    kf = KalmanFilter(dim_x=2, dim_z=1)
    kf.x, kf.P, kf.F, kf.H, kf.Q, kf.R = np.array([0.0, 1.0]), np.eye(2) * 4.0, F, H, _q(0.5), np.array([[2.0]])
    gpb = imm = ModeMixture(np.ones(1), kf.x[None].copy(), kf.P[None].copy())
    for k in range(30):
        z = k + rng.normal() * 1.4
        kf.predict()
        kf.update(z)
        step = _linear_pair_filter([_q(0.5)], [2.0], z)
        gpb, _ = gpb2_step(gpb, np.ones((1, 1)), step)
        imm = imm_step(imm, np.ones((1, 1)), lambda j, m, p: step(0, j, m, p))
    for mixture in (gpb, imm):
        np.testing.assert_allclose(mixture.means[0], kf.x, rtol=1e-10)
        np.testing.assert_allclose(mixture.covs[0], kf.P, rtol=1e-10)


def test_imm_step_equals_filterpy_imm_estimator() -> None:
    """Two constant-velocity modes (quiet, manoeuvring), row-stochastic M as FilterPy's code uses it."""
    rng = np.random.default_rng(4)
    qs, rs = [_q(0.01), _q(10.0)], [1.0, 1.0]
    m = np.array([[0.95, 0.05], [0.1, 0.9]])
    filters = []
    for q in qs:
        kf = KalmanFilter(dim_x=2, dim_z=1)
        kf.x, kf.P, kf.F, kf.H, kf.Q, kf.R = np.array([0.0, 1.0]), np.eye(2) * 4.0, F, H, q, np.array([[1.0]])
        filters.append(kf)
    reference = IMMEstimator(filters, np.array([0.6, 0.4]), m)
    ours = ModeMixture(np.array([0.6, 0.4]), np.array([[0.0, 1.0]] * 2), np.stack([np.eye(2) * 4.0] * 2))
    truth = np.array([0.0, 1.0])
    for k in range(40):
        truth = F @ truth + (np.array([0.0, 3.0]) if k == 20 else 0.0)
        z = truth[0] + rng.normal()
        reference.predict()
        reference.update(np.array([z]))
        step = _linear_pair_filter(qs, rs, z)
        ours = imm_step(ours, m, lambda j, mean, cov: step(0, j, mean, cov))
        np.testing.assert_allclose(ours.probabilities, reference.mu, rtol=1e-8)
        mean, cov = ours.collapse()
        np.testing.assert_allclose(mean, reference.x, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(cov, reference.P, rtol=1e-8)
    assert ours.probabilities[1] < 0.5  # quiet again after the jump


def test_gpb2_from_one_step_keeps_the_exact_posterior_moments() -> None:
    """From a mixture prior, one step's exact posterior has N_prev x N_new components; GPB2 collapses
    per new mode, and collapsing that again must give the exact mixture's mean and covariance."""
    rng = np.random.default_rng(5)
    qs, rs = [_q(0.1), _q(5.0), _q(1.0)], [1.0, 4.0, 0.5]
    prior = ModeMixture(np.array([0.2, 0.5, 0.3]), rng.normal(size=(3, 2)) * 3.0,
                        np.stack([np.eye(2) * s for s in (1.0, 2.0, 5.0)]))
    c = np.array([[0.8, 0.1, 0.1], [0.2, 0.7, 0.1], [0.3, 0.3, 0.4]])
    z = 2.5
    step = _linear_pair_filter(qs, rs, z)
    posterior, joint = gpb2_step(prior, c, step)
    weights, means, covs = [], [], []
    for i in range(3):  # brute force: every (i, j) component with weight w_i c_ij l_ij
        for j in range(3):
            mean, cov, log_lik = step(i, j, prior.means[i], prior.covs[i])
            weights.append(prior.probabilities[i] * c[i, j] * math.exp(log_lik))
            means.append(mean)
            covs.append(cov)
    weights = np.array(weights) / sum(weights)
    exact_mean, exact_cov = collapse(weights, np.array(means), np.array(covs))
    np.testing.assert_allclose(joint.ravel(), weights, rtol=1e-10)
    np.testing.assert_allclose(posterior.probabilities, weights.reshape(3, 3).sum(axis=0), rtol=1e-10)
    mean, cov = posterior.collapse()
    np.testing.assert_allclose(mean, exact_mean, rtol=1e-10)
    np.testing.assert_allclose(cov, exact_cov, rtol=1e-10)


def test_gpb2_picks_the_mode_that_explains_the_data() -> None:
    """Two observation models, offsets 0 and +20: data from the second makes it certain."""
    def pair(i, j, mean, cov):
        m, p = F @ mean, F @ cov @ F.T + _q(0.1)
        return kalman_update(m, p, Observation(np.array([z - 20.0 * j]), H, np.array([[1.0]])))
    mixture = ModeMixture(np.array([0.5, 0.5]), np.zeros((2, 2)), np.stack([np.eye(2)] * 2))
    c = np.array([[0.9, 0.1], [0.1, 0.9]])
    rng = np.random.default_rng(6)
    for k in range(10):
        z = 20.0 + rng.normal()
        mixture, _ = gpb2_step(mixture, c, pair)
    assert mixture.probabilities[1] > 0.99
    assert abs(mixture.collapse()[0][0]) < 2.0
