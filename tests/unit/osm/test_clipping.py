"""Cutting polylines to the box (Liang-Barsky), checked against points worked out by hand."""

from __future__ import annotations

import itertools

import pytest

from gcs.adapters.osm.clipping import clip_segment, clipped_runs

BOX = (0.0, 0.0, 10.0, 10.0)


@pytest.mark.parametrize(("p", "q", "expected"), [
    ((2, 2), (8, 8), (0.0, 1.0)),  # inside
    ((-5, 5), (15, 5), (0.25, 0.75)),  # through, west to east
    ((5, -10), (5, 5), (2 / 3, 1.0)),  # enters from the south
    ((5, 5), (5, 20), (0.0, 1 / 3)),  # leaves to the north
    ((-5, 5), (-1, 5), None),  # west of the box
    ((-2, 8), (2, 12), None),  # passes the north-west corner outside
    ((-1, 1), (1, -1), None),  # touches the corner only
    ((12, 5), (12, 5), None),  # a point outside
])
def test_clip_segment(p, q, expected) -> None:
    got = clip_segment(BOX, p, q)
    assert got == (None if expected is None else pytest.approx(expected))


def test_runs_inside_the_box_with_new_points_on_its_edge() -> None:
    line = [(1, -5.0, 5.0), (2, 5.0, 5.0), (3, 5.0, 15.0), (4, 8.0, 15.0), (5, 8.0, 5.0), (6, 9.0, 5.0)]
    runs = clipped_runs(BOX, line, itertools.count(-1, -1))
    assert [[p[0] for p in run] for run in runs] == [[-1, 2, -2], [-3, 5, 6]]
    assert [p[1:] for p in runs[0]] == [(0.0, 5.0), (5.0, 5.0), (5.0, 10.0)]
    assert [p[1:] for p in runs[1]] == [(8.0, 10.0), (8.0, 5.0), (9.0, 5.0)]
    assert clipped_runs(BOX, [(1, 20.0, 20.0), (2, 30.0, 30.0)], itertools.count(-1, -1)) == []
