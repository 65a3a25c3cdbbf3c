"""Random estimate and truth sets (seeded) and their Stone Soup ``State`` form, for the metric tests."""

from __future__ import annotations

import datetime

import numpy as np
from stonesoup.types.state import State

STAMP = datetime.datetime(2026, 1, 1)


def states(points: np.ndarray) -> list[State]:
    """Stone Soup states (2-D state vectors) at one timestamp."""
    return [State(np.asarray(p, dtype=float).reshape(2, 1), timestamp=STAMP) for p in points]


def random_sets(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Estimates (m, 2) and truths (n, 2), 0..7 points each, some near each other and some beyond any cut-off."""
    rng = np.random.default_rng(seed)
    n, m = rng.integers(0, 8, size=2)
    truths = rng.uniform(-100.0, 100.0, size=(n, 2))
    near = truths[rng.integers(0, n, size=m)] + rng.normal(0.0, 15.0, size=(m, 2)) if n else np.zeros((m, 2))
    far = rng.uniform(-100.0, 100.0, size=(m, 2))
    estimates = np.where(rng.random((m, 1)) < 0.7, near, far)
    return estimates, truths


SEEDS = range(60)
