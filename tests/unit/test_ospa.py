"""OSPA (gcs.core.metrics.ospa): hand-computed cases, and equality with Stone Soup's OSPAMetric.

Stone Soup 1.9's ``OSPAMetric.compute_OSPA_distance`` solves the assignment on the
cut-off distances, not on their p-th powers (eq. 3 of Schuhmacher et al. 2008);
``assign_on_power=False`` reproduces it exactly; eq. (3) itself can only be lower.
"""

from __future__ import annotations

import numpy as np
import pytest
from stonesoup.metricgenerator.ospametric import OSPAMetric

from gcs.core.metrics import gospa, ospa
from tests.unit.stonesoup_sets import SEEDS, random_sets, states


def test_hand_computed():
    # truths (0, 0), (10, 0); one estimate (0, 3): min over pi = 3^2, plus c^2 (2 - 1) = 25: sqrt((9 + 25) / 2)
    assert ospa([[0.0, 3.0]], [[0.0, 0.0], [10.0, 0.0]], c=5.0, p=2.0) == pytest.approx(np.sqrt(17.0))
    assert ospa([], [], c=5.0) == 0.0
    assert ospa([], [[1.0, 2.0]], c=5.0) == 5.0
    assert ospa([[0.0, 0.0]], [[0.0, 1.0]], c=5.0, p=np.inf) == pytest.approx(1.0)
    assert ospa([[0.0, 0.0]], [[0.0, 1.0], [3.0, 3.0]], c=5.0, p=np.inf) == 5.0


def test_assignment_on_powers_can_beat_the_assignment_on_distances():
    # truths (0, 0), (3, 0); estimate a at 1 m from the first and 2.6 m from the second, b at 2.6 m and 4 m.
    # On distances pairing (a, b) -> (first, second) costs 1 + 4 = 5 < 2.6 + 2.6 = 5.2; on squares it costs
    # 17 > 13.52. Eq. (3) (p = 2): sqrt(13.52 / 2) = 2.6; Stone Soup's rule: sqrt(17 / 2).
    x = np.array([[0.54, np.sqrt(1.0 - 0.54**2)], [-0.04, -np.sqrt(6.76 - 0.04**2)]])
    y = np.array([[0.0, 0.0], [3.0, 0.0]])
    assert ospa(x, y, c=100.0, p=2.0) == pytest.approx(2.6)
    assert ospa(x, y, c=100.0, p=2.0, assign_on_power=False) == pytest.approx(np.sqrt(8.5))
    assert OSPAMetric(c=100.0, p=2.0).compute_OSPA_distance(states(x), states(y)).value == pytest.approx(np.sqrt(8.5))
    for seed in SEEDS:  # the powers rule is the minimum of eq. (3): never above the distances rule
        estimates, truths = random_sets(seed)
        assert ospa(estimates, truths, 20.0, 3.0) <= ospa(estimates, truths, 20.0, 3.0, assign_on_power=False) + 1e-12


def test_ospa_and_gospa_agree_on_equal_cardinalities_inside_the_cutoff():
    # with |X| = |Y| = n and every optimal pair closer than c, GOSPA^p = n * OSPA^p
    x = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    y = x + np.array([[1.0, 0.0], [0.0, -2.0], [0.5, 0.5]])
    assert gospa(x, y, c=5.0, p=2.0).distance ** 2 == pytest.approx(3 * ospa(x, y, c=5.0, p=2.0) ** 2)


@pytest.mark.parametrize("c, p", [(20.0, 1.0), (20.0, 2.0), (50.0, 3.0)])
def test_equals_stone_soup(c, p):
    metric = OSPAMetric(c=c, p=p)
    compared = 0
    for seed in SEEDS:
        estimates, truths = random_sets(seed)
        if len(estimates) + len(truths) == 0:  # Stone Soup needs a timestamp, so at least one state
            continue
        theirs = metric.compute_OSPA_distance(states(estimates), states(truths)).value
        assert ospa(estimates, truths, c=c, p=p, assign_on_power=False) == pytest.approx(theirs, rel=1e-9, abs=1e-9)
        if p == 1.0:
            assert ospa(estimates, truths, c=c, p=p) == pytest.approx(theirs, rel=1e-9, abs=1e-9)
        compared += 1
    assert compared > 50


def test_equals_stone_soup_for_infinite_order():
    metric = OSPAMetric(c=20.0, p=np.inf)
    for seed in SEEDS:
        estimates, truths = random_sets(seed)
        if len(estimates) + len(truths) == 0:
            continue
        theirs = metric.compute_OSPA_distance(states(estimates), states(truths)).value
        assert ospa(estimates, truths, c=20.0, p=np.inf) == pytest.approx(theirs)
