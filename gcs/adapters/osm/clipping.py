"""Cutting OSM ways to a longitude-latitude box: runs of points inside it, new points where a way crosses its edge.

A box ``(west, south, east, north)`` in degrees contains ``(lon, lat)`` when
``west <= lon <= east`` and ``south <= lat <= north``. A segment ``p -> q`` is cut
to the box by the Liang-Barsky parametric clip: with ``x(t) = p + t (q - p)``,
``t in [0, 1]``, each of the four edges bounds ``t`` from one side (``t >= r`` where
the segment enters across it, ``t <= r`` where it leaves), and the segment's part
inside is ``[max of the lower bounds, min of the upper bounds]`` when that is not
empty (Liang and Barsky, "A new concept and method for line clipping", ACM
Transactions on Graphics 3(1), 1984). At the sizes of a city, degrees are close
enough to a plane for the cut point (a few metres of a segment) to be right to
well under a centimetre.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

__all__ = ["Box", "box_text", "inside", "clip_segment", "clipped_runs"]

Box = tuple[float, float, float, float]
"""``west, south, east, north``, degrees."""
Point = tuple[int, float, float]
"""``(key, lon, lat)``: an OSM node id, or a negative key for a point made at the box's edge."""


def box_text(box: Sequence[float]) -> str:
    """``W,S,E,N`` as the command line takes it, every digit kept."""
    return ",".join(repr(float(value)) for value in box)


def inside(box: Box, lon: float, lat: float) -> bool:
    """Whether ``(lon, lat)`` lies in ``box`` (edges included)."""
    west, south, east, north = box
    return west <= lon <= east and south <= lat <= north


def clip_segment(box: Box, p: tuple[float, float], q: tuple[float, float]) -> tuple[float, float] | None:
    """``(t0, t1)``, the part of ``p -> q`` inside ``box`` (module docstring), or None when it misses the box."""
    west, south, east, north = box
    dx, dy = q[0] - p[0], q[1] - p[1]
    t0, t1 = 0.0, 1.0
    for step, room in ((-dx, p[0] - west), (dx, east - p[0]), (-dy, p[1] - south), (dy, north - p[1])):
        if step == 0.0:
            if room < 0.0:
                return None  # parallel to this edge and outside it
            continue
        r = room / step
        if step < 0.0:
            t0 = max(t0, r)  # entering across this edge
        else:
            t1 = min(t1, r)  # leaving across it
        if t0 > t1:
            return None
    if t0 == t1 and (dx or dy):
        return None  # touches a corner of the box only
    return t0, t1


def clipped_runs(box: Box, points: Sequence[Point], new_key: Iterator[int]) -> list[list[Point]]:
    """The runs of a polyline inside ``box``: its points inside, and a new point (key from ``new_key``) wherever
    it crosses the edge. Runs of fewer than two points are left out."""
    runs: list[list[Point]] = []
    run: list[Point] = []
    for a, b in zip(points, points[1:]):
        part = clip_segment(box, a[1:], b[1:])
        if part is None:
            _close(runs, run)
            run = []
            continue
        t0, t1 = part
        if t0 > 0.0 or not run:
            _close(runs, run)
            run = [a if t0 == 0.0 else _at(a, b, t0, next(new_key))]
        run.append(b if t1 == 1.0 else _at(a, b, t1, next(new_key)))
        if t1 < 1.0:
            _close(runs, run)
            run = []
    _close(runs, run)
    return runs


def _at(a: Point, b: Point, t: float, key: int) -> Point:
    return key, a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])


def _close(runs: list[list[Point]], run: list[Point]) -> None:
    if len(run) >= 2:
        runs.append(run)
