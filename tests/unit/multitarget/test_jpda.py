"""JPDA marginals against a brute-force enumeration written here from the event probabilities."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.multitarget.gnn import assignment_costs, gnn_assign
from gcs.core.multitarget.jpda import clusters, jpda_marginals

PD, PG, CLUTTER = 0.85, 0.99, 2e-4


def _brute_force_beta(likelihood: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Enumerate, detection by detection, every feasible joint event (clutter, or a free gating track), weighted
    P(theta) ∝ prod_detected PD N / lambda * prod_missed (1 - PD PG); return the marginals beta (T, n)."""
    tracks, detections = valid.shape
    beta = np.zeros((tracks, detections))
    events: list[tuple[list[int], float]] = []

    def extend(j: int, owner: list[int]) -> None:
        if j == detections:
            used = {t for t in owner if t >= 0}
            weight = 1.0
            for d, t in enumerate(owner):
                if t >= 0:
                    weight *= PD * likelihood[t, d] / CLUTTER
            weight *= (1.0 - PD * PG) ** (tracks - len(used))
            events.append((owner, weight))
            return
        extend(j + 1, owner + [-1])
        for t in range(tracks):
            if valid[t, j] and t not in owner:
                extend(j + 1, owner + [t])

    extend(0, [])
    total = sum(w for _, w in events)
    for owner, weight in events:
        for d, t in enumerate(owner):
            if t >= 0:
                beta[t, d] += weight / total
    return beta


@pytest.mark.parametrize("seed", range(40))
def test_marginals_equal_brute_force_enumeration(seed: int) -> None:
    rng = np.random.default_rng(seed)
    tracks, detections = int(rng.integers(1, 5)), int(rng.integers(0, 6))
    log_likelihood = rng.normal(-9.0, 2.0, (tracks, detections))
    valid = rng.random((tracks, detections)) < 0.5
    costs = assignment_costs(log_likelihood, valid, PD, PG, CLUTTER)
    result = jpda_marginals(costs, valid)
    want = _brute_force_beta(np.exp(log_likelihood), valid)
    np.testing.assert_allclose(result.beta, want, rtol=1e-9, atol=1e-12)
    assert (result.beta.sum(axis=1) <= 1.0 + 1e-12).all()
    assert (result.beta.sum(axis=0) <= 1.0 + 1e-12).all()  # a detection is at most one track's
    assert (result.beta[~valid] == 0.0).all()
    assert result.clusters_over_cap == 0


def test_clusters_are_the_connected_components_of_the_gate() -> None:
    valid = np.array([[1, 1, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]], dtype=bool)
    found = sorted((t.tolist(), d.tolist()) for t, d in clusters(valid))
    assert found == [([0, 1], [0, 1]), ([2], [3])]


def test_a_cluster_over_the_cap_is_associated_by_gnn_and_counted() -> None:
    rng = np.random.default_rng(3)
    log_likelihood = rng.normal(-9.0, 2.0, (4, 5))
    valid = np.ones((4, 5), dtype=bool)
    costs = assignment_costs(log_likelihood, valid, PD, PG, CLUTTER)
    result = jpda_marginals(costs, valid, max_hypotheses=100)  # 6^4 = 1296 combinations
    assert result.clusters_over_cap == 1
    assigned = gnn_assign(costs)
    expected = np.zeros((4, 5))
    expected[np.flatnonzero(assigned >= 0), assigned[assigned >= 0]] = 1.0
    np.testing.assert_array_equal(result.beta, expected)
    assert jpda_marginals(costs, valid, max_hypotheses=1296).clusters_over_cap == 0
