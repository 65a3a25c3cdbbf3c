"""GNN: the assignment of least total cost, against a brute-force search over every feasible assignment."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from gcs.core.multitarget.gnn import assignment_costs, gnn_assign


def _brute_force(costs: np.ndarray) -> tuple[float, tuple[int, ...]]:
    """Least total cost over every way to give each track one finite-cost detection or none, injectively."""
    tracks, detections = costs.shape
    best = (0.0, (-1,) * tracks)
    options = [[-1] + [j for j in range(detections) if np.isfinite(costs[t, j])] for t in range(tracks)]
    for choice in itertools.product(*options):
        taken = [j for j in choice if j >= 0]
        if len(taken) != len(set(taken)):
            continue
        total = sum(costs[t, j] for t, j in enumerate(choice) if j >= 0)
        if total < best[0]:
            best = (total, choice)
    return best


def test_costs_are_the_negative_log_likelihood_ratio() -> None:
    log_likelihood = np.array([[-3.0, -20.0]])
    valid = np.array([[True, False]])
    costs = assignment_costs(log_likelihood, valid, 0.9, 0.99, 1e-4)
    assert costs[0, 0] == pytest.approx(-math.log(0.9 * math.exp(-3.0) / (1e-4 * (1 - 0.9 * 0.99))))
    assert costs[0, 1] == math.inf


@pytest.mark.parametrize("seed", range(40))
def test_gnn_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    tracks, detections = int(rng.integers(1, 5)), int(rng.integers(0, 6))
    log_likelihood = rng.normal(-8.0, 3.0, (tracks, detections))
    valid = rng.random((tracks, detections)) < 0.6
    costs = assignment_costs(log_likelihood, valid, 0.9, 0.99, 1e-4)
    assigned = gnn_assign(costs)
    best_cost, best_choice = _brute_force(costs)
    total = sum(costs[t, j] for t, j in enumerate(assigned) if j >= 0)
    assert total == pytest.approx(best_cost, abs=1e-9)
    assert tuple(assigned.tolist()) == best_choice
    taken = assigned[assigned >= 0]
    assert len(set(taken.tolist())) == taken.size


def test_gnn_leaves_a_track_unassigned_when_its_only_pair_costs_more_than_a_miss() -> None:
    costs = np.array([[2.0, np.inf], [-1.0, np.inf]])
    assert gnn_assign(costs).tolist() == [-1, 0]
