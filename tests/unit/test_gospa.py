"""GOSPA (gcs.core.metrics.gospa): hand-computed cases, and equality with Stone Soup's GOSPAMetric.

Stone Soup 1.9's ``GOSPAMetric`` uses alpha = 2 (set in its ``__init__``), raises
``distance`` to 1/p and leaves ``localisation``, ``missed`` and ``false`` as the
p-th-power parts; its switching penalty defaults to 0 and is set to 0 here
explicitly, so ``distance`` is the plain GOSPA.
"""

from __future__ import annotations

import numpy as np
import pytest
from stonesoup.metricgenerator.ospametric import GOSPAMetric

from gcs.core.metrics import gospa
from tests.unit.stonesoup_sets import SEEDS, random_sets, states


def test_hand_computed_one_pair_one_missed_one_false():
    # truths (0, 0) and (100, 0); estimates (3, 4) (5 m from the first) and (0, 50) (beyond c of both truths
    # once (3, 4) takes the first); c = 10, p = 2: 5^2 + 10^2/2 (missed) + 10^2/2 (false) = 125.
    result = gospa([[3.0, 4.0], [0.0, 50.0]], [[0.0, 0.0], [100.0, 0.0]], c=10.0, p=2.0)
    assert result.localisation == pytest.approx(25.0)
    assert result.missed == pytest.approx(50.0)
    assert result.false == pytest.approx(50.0)
    assert result.distance == pytest.approx(np.sqrt(125.0))
    assert result.assignment.tolist() == [0, -1]
    assert (result.missed_count, result.false_count) == (1, 1)


def test_hand_computed_p1_prefers_two_pairs_inside_cutoff():
    # p = 1, c = 4: truths 0 and 3 on a line, estimates 2 and 5. Pairing (2->0, 5->3) costs 2 + 2 = 4;
    # pairing (2->3) alone costs 1 + 2 + 2 = 5 (one missed, one false at c/2 each). GOSPA = 4.
    result = gospa([[2.0, 0.0], [5.0, 0.0]], [[0.0, 0.0], [3.0, 0.0]], c=4.0, p=1.0)
    assert result.distance == pytest.approx(4.0)
    assert result.assignment.tolist() == [0, 1]


def test_empty_sets():
    both = gospa(np.zeros((0, 2)), [], c=5.0, p=2.0)
    assert (both.distance, both.missed, both.false) == (0.0, 0.0, 0.0)
    no_tracks = gospa([], [[0.0, 0.0], [1.0, 1.0], [9.0, 9.0]], c=5.0, p=2.0)
    assert no_tracks.distance == pytest.approx(np.sqrt(3 * 25.0 / 2))  # (c^p/2 * n)^(1/p)
    assert no_tracks.missed_count == 3 and no_tracks.false == 0.0


def test_pair_at_exactly_the_cutoff_is_missed_and_false():
    result = gospa([[10.0, 0.0]], [[0.0, 0.0]], c=10.0, p=2.0)
    assert result.assignment.tolist() == [-1]
    assert (result.localisation, result.missed, result.false) == (0.0, 50.0, 50.0)


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError):
        gospa([[0.0, 0.0]], [[0.0, 0.0]], c=0.0)
    with pytest.raises(ValueError):
        gospa([[0.0, 0.0]], [[0.0, 0.0]], c=1.0, p=0.5)
    with pytest.raises(ValueError):
        gospa([[0.0, 0.0, 0.0]], [[0.0, 0.0]], c=1.0)


@pytest.mark.parametrize("c, p", [(20.0, 1.0), (20.0, 2.0), (50.0, 3.0)])
def test_equals_stone_soup(c, p):
    metric = GOSPAMetric(c=c, p=p, switching_penalty=0.0)
    assert metric.alpha == 2
    compared = 0
    for seed in SEEDS:
        estimates, truths = random_sets(seed)
        ours = gospa(estimates, truths, c=c, p=p)
        if len(estimates) + len(truths) == 0:  # Stone Soup needs a timestamp, so at least one state
            continue
        theirs, _ = metric.compute_gospa_metric(states(estimates), states(truths))
        for key in ("distance", "localisation", "missed", "false"):
            assert getattr(ours, key) == pytest.approx(theirs.value[key], rel=1e-9, abs=1e-9), (seed, key)
        compared += 1
    assert compared > 50


def test_sets_cover_empty_and_mismatched_cardinalities():
    sizes = [tuple(len(s) for s in random_sets(seed)) for seed in SEEDS]
    assert any(m == 0 < n for m, n in sizes) and any(n == 0 < m for m, n in sizes)
    assert any(m > n > 0 for m, n in sizes) and any(n > m > 0 for m, n in sizes)


def test_metric_axioms_on_random_sets():
    # GOSPA is a metric for 1 <= p < inf (Rahmathullah et al. 2017): symmetric, with the missed and
    # false parts exchanged, and obeying the triangle inequality.
    for seed in SEEDS:
        x, y = random_sets(seed)
        z, _ = random_sets(seed + 1000)
        forward, backward = gospa(x, y, c=20.0, p=2.0), gospa(y, x, c=20.0, p=2.0)
        assert forward.distance == pytest.approx(backward.distance)
        assert (forward.missed, forward.false) == pytest.approx((backward.false, backward.missed))
        via = gospa(x, z, c=20.0, p=2.0).distance + gospa(z, y, c=20.0, p=2.0).distance
        assert forward.distance <= via + 1e-9
    assert gospa(x, x, c=20.0).distance == 0.0
