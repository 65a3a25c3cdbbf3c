"""line_of_sight: known geometry, documented tangency, symmetry, and an independent oracle."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.core.world import Buildings, generate_city, line_of_sight

CITY, STREETS = generate_city(np.random.default_rng(2012))
BOX = Buildings.from_polygons([[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]], [20.0])
L_SHAPE = Buildings.from_polygons([[(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, 20.0), (0.0, 20.0)]],
                                  [30.0])


def los(buildings: Buildings, a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return bool(line_of_sight(buildings, a, b))


# --- A single building ---------------------------------------------------------------------


def test_segment_through_the_middle_below_the_roof_is_blocked_above_it_is_not() -> None:
    assert not los(BOX, (-5.0, 5.0, 10.0), (15.0, 5.0, 10.0))
    assert los(BOX, (-5.0, 5.0, 25.0), (15.0, 5.0, 25.0))
    # Rising across: at the near wall (x = 0) the sight line is at z = 10 < 20.
    assert not los(BOX, (-5.0, 5.0, 0.0), (15.0, 5.0, 40.0))
    # Rising steeply: already at z = 25 over the near wall, so clear; less steep, z = 15 there: blocked.
    assert los(BOX, (-5.0, 5.0, 0.0), (5.0, 5.0, 50.0))
    assert not los(BOX, (-5.0, 5.0, 0.0), (5.0, 5.0, 30.0))


def test_grazing_contact_does_not_block() -> None:
    """The documented tangency rule: touching the boundary only is not blocking."""
    assert los(BOX, (-5.0, 0.0, 10.0), (15.0, 0.0, 10.0))  # along the south wall
    assert los(BOX, (10.0, -5.0, 10.0), (10.0, 15.0, 10.0))  # along the east wall
    assert los(BOX, (-5.0, 5.0, 10.0), (5.0, -5.0, 10.0))  # touches the corner (0, 0) only
    assert los(BOX, (-5.0, 5.0, 20.0), (15.0, 5.0, 20.0))  # along the roof plane
    assert los(BOX, (-5.0, 5.0, 10.0), (0.0, 5.0, 10.0))  # ends on the wall
    assert los(BOX, (-5.0, 5.0, 40.0), (5.0, 5.0, 20.0))  # ends on the roof
    assert not los(BOX, (-5.0, 5.0, 10.0), (0.5, 5.0, 10.0))  # ends just inside
    assert not los(BOX, (-5.0, 5.0, 19.999), (15.0, 5.0, 19.999))  # just below the roof
    assert not los(BOX, (-5.0, 0.001, 10.0), (15.0, 0.001, 10.0))  # just inside the south wall


def test_non_convex_footprint_degenerate_cases() -> None:
    # Along the inner walls of the L (interior on one side only): not blocked.
    assert los(L_SHAPE, (15.0, 10.0, 5.0), (25.0, 10.0, 5.0))
    assert los(L_SHAPE, (10.0, 25.0, 5.0), (10.0, 15.0, 5.0))
    # Through the notch, missing the building: not blocked.
    assert los(L_SHAPE, (15.0, 25.0, 5.0), (25.0, 15.0, 5.0))
    # Through the reflex vertex (10, 10) into the interior: blocked.
    assert not los(L_SHAPE, (15.0, 15.0, 5.0), (5.0, 5.0, 5.0))
    # Ending on the reflex vertex from the notch, touching a convex corner from outside: not blocked.
    assert los(L_SHAPE, (15.0, 15.0, 5.0), (10.0, 10.0, 5.0))
    assert los(L_SHAPE, (25.0, 5.0, 5.0), (15.0, -5.0, 5.0))
    # Touching the tips of both arms, (10, 20) and (20, 10): not blocked; a little lower: blocked.
    assert los(L_SHAPE, (5.0, 25.0, 5.0), (25.0, 5.0, 5.0))
    assert not los(L_SHAPE, (0.0, 25.0, 5.0), (25.0, 0.0, 5.0))


def test_vertical_segments() -> None:
    assert not los(BOX, (5.0, 5.0, 0.0), (5.0, 5.0, 30.0))  # from inside the building up through the roof
    assert los(BOX, (5.0, 5.0, 20.0), (5.0, 5.0, 30.0))  # from the roof up
    assert los(BOX, (15.0, 5.0, 0.0), (15.0, 5.0, 30.0))  # beside the building
    assert los(BOX, (5.0, 5.0, 10.0), (5.0, 5.0, 10.0))  # a point


def test_broadcasting_and_validation() -> None:
    target = np.array([-5.0, 5.0, 0.0])
    vehicles = np.stack(np.broadcast_arrays(15.0, np.linspace(-20.0, 30.0, 6)[:, None],
                                            np.array([5.0, 50.0, 500.0])), axis=-1)
    result = line_of_sight(BOX, target, vehicles)
    assert result.shape == (6, 3) and result.dtype == bool
    assert line_of_sight(Buildings.empty(), target, vehicles).all()
    with pytest.raises(ValueError, match="shape"):
        line_of_sight(BOX, [0.0, 0.0], [1.0, 1.0, 1.0])


# --- The generated city --------------------------------------------------------------------

coordinate = st.floats(-100.0, 3100.0, allow_nan=False)
height = st.floats(0.0, 250.0, allow_nan=False)


@settings(max_examples=300)
@given(coordinate, coordinate, height, coordinate, coordinate, height)
def test_line_of_sight_is_symmetric(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> None:
    a, b = (ax, ay, az), (bx, by, bz)
    assert los(CITY, a, b) == los(CITY, b, a)


def test_line_of_sight_is_symmetric_in_bulk() -> None:
    rng = np.random.default_rng(11)
    a = np.c_[rng.uniform(-100, 3100, (5000, 2)), rng.uniform(0, 250, 5000)]
    b = a + np.c_[rng.normal(0, 300, (5000, 2)), rng.normal(0, 60, 5000)]
    forward, backward = line_of_sight(CITY, a, b), line_of_sight(CITY, b, a)
    np.testing.assert_array_equal(forward, backward)
    assert 0.1 < forward.mean() < 0.9


def test_vehicle_above_every_roof_straight_over_the_target_sees_it() -> None:
    rng = np.random.default_rng(5)
    on_street = STREETS.nearest_intersection(rng.uniform(0, 3000, (500, 2))) + rng.uniform(-14, 14, (500, 2))
    targets = np.c_[on_street, np.zeros(500)]
    vehicles = targets + [0.0, 0.0, CITY.heights.max() + 1.0]
    assert line_of_sight(CITY, targets, vehicles).all()
    # ... and a target inside a building is hidden even from straight above.
    box = CITY.bbox[:50]
    inside = np.c_[0.5 * (box[:, :2] + box[:, 2:]), np.zeros(50)]
    assert not line_of_sight(CITY, inside, inside + [0.0, 0.0, 500.0]).any()


COURTYARD = Buildings.from_boxes(
    [[-30.0, -30.0, 30.0, -20.0], [20.0, -20.0, 30.0, 20.0], [-30.0, 20.0, 30.0, 30.0], [-30.0, -20.0, -20.0, 20.0]],
    [50.0] * 4,
)
"""A closed ring of four 50 m buildings around a 40 m x 40 m courtyard centred on the origin."""


def _entry_distance(theta: np.ndarray) -> np.ndarray:
    """Horizontal distance from the courtyard's centre to its inner walls along azimuth theta."""
    return 20.0 / np.maximum(np.abs(np.cos(theta)), np.abs(np.sin(theta)))


@pytest.mark.parametrize("altitude", [60.0, 150.0, 400.0])
def test_courtyard_target_is_seen_only_from_high_elevation(altitude: float) -> None:
    """Visible iff the sight line clears the 50 m inner wall: altitude * s1 / D >= 50."""
    rng = np.random.default_rng(int(altitude))
    theta = rng.uniform(-np.pi, np.pi, 4000)
    distance = rng.uniform(0.0, 1000.0, 4000)
    vehicles = np.stack([distance * np.cos(theta), distance * np.sin(theta), np.full(4000, altitude)], axis=-1)
    seen = line_of_sight(COURTYARD, [0.0, 0.0, 0.0], vehicles)
    clear = altitude * _entry_distance(theta) / distance
    decided = np.abs(clear - 50.0) > 1e-6  # leave out the measure-zero boundary
    np.testing.assert_array_equal(seen[decided], (clear >= 50.0)[decided])
    assert seen.any() and not seen.all()
    assert line_of_sight(COURTYARD, [0.0, 0.0, 0.0], [[5.0, -3.0, 60.0], [0.0, 0.0, 60.0]]).all()  # overhead
    # Low elevation: hidden from every direction outside the ring.
    ring = np.stack([500 * np.cos(theta), 500 * np.sin(theta), np.full(4000, 100.0)], axis=-1)
    assert not line_of_sight(COURTYARD, [0.0, 0.0, 0.0], ring).any()


def test_u_shaped_courtyard_is_open_to_the_missing_side() -> None:
    u_shape = Buildings.from_boxes(COURTYARD.bbox[:2].tolist() + [COURTYARD.bbox[3].tolist()], [50.0] * 3)
    north = np.array([[0.0, 500.0, 10.0], [10.0, 300.0, 5.0]])
    south = north * [1.0, -1.0, 1.0]
    assert line_of_sight(u_shape, [0.0, 0.0, 0.0], north).all()
    assert not line_of_sight(u_shape, [0.0, 0.0, 0.0], south).any()


# --- Independent oracle ----------------------------------------------------------------------


def _inside(x: float, y: float, ring: list[tuple[float, float]]) -> bool:
    """Winding number of the ring around (x, y) is non-zero (the ring is simple)."""
    winding = 0
    for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1]):
        side = (x1 - x0) * (y - y0) - (x - x0) * (y1 - y0)
        if y0 <= y < y1 and side > 0:
            winding += 1
        elif y1 <= y < y0 and side < 0:
            winding -= 1
    return winding != 0


def _oracle_blocked(a: tuple[float, ...], b: tuple[float, ...], ring: list[tuple[float, float]], roof: float) -> bool:
    """Cut the segment at every crossing with a wall line and with the ground and roof planes,
    and test the midpoint of every piece for being strictly inside the prism."""
    ax, ay, az = a
    dx, dy, dz = b[0] - ax, b[1] - ay, b[2] - az
    cuts = {0.0, 1.0}
    for (x0, y0), (x1, y1) in zip(ring, ring[1:] + ring[:1]):
        ex, ey = x1 - x0, y1 - y0
        denominator = dx * ey - dy * ex
        if denominator != 0.0:
            t = ((x0 - ax) * ey - (y0 - ay) * ex) / denominator
            u = ((x0 - ax) * dy - (y0 - ay) * dx) / denominator
            if 0.0 < t < 1.0 and -1e-9 <= u <= 1.0 + 1e-9:
                cuts.add(t)
    if dz != 0.0:
        cuts.update(t for t in (-az / dz, (roof - az) / dz) if 0.0 < t < 1.0)
    ordered = sorted(cuts)
    for t0, t1 in zip(ordered, ordered[1:]):
        t = 0.5 * (t0 + t1)
        z = az + t * dz
        if 0.0 < z < roof and _inside(ax + t * dx, ay + t * dy, ring):
            return True
    return False


def _oracle_los(buildings: Buildings, a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    lo = (min(a[0], b[0]), min(a[1], b[1]), min(a[2], b[2]))
    hi = (max(a[0], b[0]), max(a[1], b[1]))
    for footprint, roof, box in zip(buildings.footprints, buildings.heights.tolist(), buildings.bbox.tolist()):
        if lo[0] > box[2] or hi[0] < box[0] or lo[1] > box[3] or hi[1] < box[1] or lo[2] >= roof:
            continue
        if _oracle_blocked(a, b, [tuple(p) for p in footprint.tolist()], roof):
            return False
    return True


def _star_city(rng: np.random.Generator, count: int) -> Buildings:
    """Random star-shaped (mostly non-convex) footprints, 5-12 vertices, overlapping freely."""
    polygons = []
    for _ in range(count):
        k = int(rng.integers(5, 13))
        theta = np.sort(rng.uniform(0.0, 2 * np.pi, k))
        radius = rng.uniform(8.0, 60.0) * rng.uniform(0.3, 1.0, k)
        centre = rng.uniform(0.0, 1000.0, 2)
        polygons.append(centre + np.c_[radius * np.cos(theta), radius * np.sin(theta)])
    return Buildings.from_polygons(polygons, rng.uniform(5.0, 80.0, count))


@pytest.mark.parametrize(
    ("city", "extent", "seed"),
    [(CITY, 3000.0, 1), (_star_city(np.random.default_rng(8), 120), 1000.0, 2)],
    ids=["generated", "star-shaped"],
)
def test_line_of_sight_matches_an_independent_oracle(city: Buildings, extent: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    count = 400
    a = np.c_[rng.uniform(0, extent, (count, 2)), rng.uniform(0.0, 40.0, count)]
    span = rng.choice([50.0, 300.0, 2000.0], count)[:, None]
    b = np.c_[a[:, :2] + rng.uniform(-1, 1, (count, 2)) * span, rng.uniform(0.0, 250.0, count)]
    fast = line_of_sight(city, a, b)
    slow = np.array([_oracle_los(city, tuple(p), tuple(q)) for p, q in zip(a.tolist(), b.tolist())])
    np.testing.assert_array_equal(fast, slow)
    assert 0.15 < slow.mean() < 0.85  # both answers well represented


def test_oracle_itself_sees_the_obvious() -> None:
    ring = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
    assert _oracle_blocked((-5.0, 5.0, 10.0), (15.0, 5.0, 10.0), ring, 20.0)
    assert not _oracle_blocked((-5.0, 5.0, 25.0), (15.0, 5.0, 25.0), ring, 20.0)
    assert math.isclose(float(_entry_distance(np.array(np.pi / 4))), 20.0 * math.sqrt(2.0))


def test_non_finite_points_are_not_visible() -> None:
    a = np.array([[-5.0, 5.0, 25.0], [np.nan, 5.0, 25.0], [-5.0, 5.0, 25.0], [-np.inf, 5.0, 25.0]])
    b = np.array([[15.0, 5.0, 25.0], [15.0, 5.0, 25.0], [15.0, np.inf, 25.0], [15.0, 5.0, 25.0]])
    assert line_of_sight(BOX, a, b).tolist() == [True, False, False, False]
