"""VisibilityMap.visible gives exactly line_of_sight's answers (plus range), for many points."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.world import (
    Buildings,
    VisibilityMap,
    VisibilityMaps,
    World,
    generate_city,
    line_of_sight,
    visibility_map,
    visibility_maps,
)

from tests.unit.test_world_los import _star_city

CITY, STREETS = generate_city(np.random.default_rng(2012))


STARS = _star_city(np.random.default_rng(8), 120)


def _reference(m: VisibilityMap, xy: np.ndarray) -> np.ndarray:
    """What the map must answer: line_of_sight and the 3-D range limit."""
    tx, ty, tz = m.target_xyz
    vehicles = np.concatenate([xy, np.full(xy.shape[:-1] + (1,), m.altitude_m)], axis=-1)
    dx, dy, dz = xy[..., 0] - tx, xy[..., 1] - ty, m.altitude_m - tz
    in_range = dx * dx + dy * dy + dz * dz <= m.max_range_m * m.max_range_m
    return line_of_sight(m.buildings, [tx, ty, tz], vehicles) & in_range


def _queries(m: VisibilityMap, rng: np.random.Generator, extent: float) -> np.ndarray:
    """Uniform points, points near the target, points on and around the region's boundary,
    points on sector boundaries and axis directions, and the target's own position."""
    target = m.target_xyz[:2]
    uniform = rng.uniform(-0.1 * extent, 1.1 * extent, (4000, 2))
    near = target + rng.normal(0.0, 80.0, (2000, 2))
    theta = rng.uniform(-np.pi, np.pi, 1000)
    reach = m.max_visible_range(theta)[:, None]
    direction = np.c_[np.cos(theta), np.sin(theta)]
    boundary = np.concatenate([target + reach * scale * direction for scale in (1.0, 1 - 1e-9, 1 + 1e-9, 0.99, 1.01)])
    sectors = -np.pi + np.arange(m.bins) * (2 * np.pi / m.bins)
    on_edges = target + rng.uniform(0, extent, (m.bins, 1)) * np.c_[np.cos(sectors), np.sin(sectors)]
    axes = target + np.array([[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0], [0.0, -100.0], [0.0, 0.0], [1e-7, 0.0]])
    return np.concatenate([uniform, near, boundary, on_edges, axes])


TARGETS = [
    ("street", (1503.3, 1540.7), 0.0),
    ("crossing", (1350.0, 2100.0), 0.0),
    ("near a corner", (float(CITY.bbox[77, 0]) - 0.5, float(CITY.bbox[77, 1]) - 0.5), 0.0),
    ("on a wall", (float(CITY.bbox[150, 0]), 0.5 * float(CITY.bbox[150, 1] + CITY.bbox[150, 3])), 0.0),
    ("inside a building", tuple(0.5 * (CITY.bbox[200, :2] + CITY.bbox[200, 2:])), 0.0),
    ("in line with a wall", (float(CITY.bbox[40, 0]), float(CITY.bbox[40, 3]) + 70.0), 0.0),
    ("city edge, raised", (10.0, 2990.0), 1.5),
]


@pytest.mark.parametrize(("altitude", "max_range"), [(200.0, 5000.0), (100.0, 5000.0), (60.0, 900.0)])
@pytest.mark.parametrize(("name", "target", "target_height"), TARGETS, ids=[t[0] for t in TARGETS])
def test_visible_equals_line_of_sight_in_the_generated_city(
    name: str, target: tuple[float, float], target_height: float, altitude: float, max_range: float
) -> None:
    m = visibility_map(CITY, target, altitude, max_range, target_height_m=target_height)
    rng = np.random.default_rng([t[0] for t in TARGETS].index(name) * 1000 + int(altitude))
    xy = _queries(m, rng, 3000.0)
    expected = _reference(m, xy)
    np.testing.assert_array_equal(m.visible(xy), expected)
    if name == "inside a building":
        assert not expected.any()
    else:
        assert expected.any() and not expected.all()


@pytest.mark.parametrize("bins", [8, 97, 1024, 4096])
@pytest.mark.parametrize("altitude", [40.0, 150.0])
def test_visible_equals_line_of_sight_among_non_convex_buildings(bins: int, altitude: float) -> None:
    rng = np.random.default_rng(bins)
    for target in rng.uniform(0.0, 1000.0, (4, 2)):
        m = visibility_map(STARS, target, altitude, 2000.0, bins=bins)
        xy = _queries(m, rng, 1000.0)
        np.testing.assert_array_equal(m.visible(xy), _reference(m, xy))


def test_visible_keeps_the_query_shape() -> None:
    m = visibility_map(CITY, (1503.3, 1540.7), 200.0, 5000.0)
    xy = np.random.default_rng(0).uniform(0, 3000, (3, 4, 2))
    assert m.visible(xy).shape == (3, 4)
    assert m.visible([1503.3, 1540.7]).shape == ()
    np.testing.assert_array_equal(m.visible(xy), _reference(m, xy))


def test_max_visible_range_bounds_the_region_along_each_ray() -> None:
    m = visibility_map(CITY, (1503.3, 1540.7), 150.0, 5000.0)
    theta = np.random.default_rng(4).uniform(-np.pi, np.pi, 3000)
    reach = m.max_visible_range(theta)
    assert np.all((reach > 0.0) & (reach <= m.horizontal_range_m))
    limited = reach < m.horizontal_range_m
    assert limited.mean() > 0.9  # the city hides a ground target from most directions at 150 m
    direction = np.c_[np.cos(theta), np.sin(theta)][limited]
    before = m.target_xyz[:2] + (reach[limited, None] - 1e-3) * direction
    after = m.target_xyz[:2] + (reach[limited, None] + 1e-3) * direction
    assert m.visible(before).all()
    assert not m.visible(after).any()


def test_empty_city_and_range_limit() -> None:
    m = visibility_map(Buildings.empty(), (0.0, 0.0), 300.0, 500.0)
    assert m.horizontal_range_m == pytest.approx(400.0)
    np.testing.assert_array_equal(m.visible([[399.0, 0.0], [0.0, -401.0], [0.0, 0.0]]), [True, False, True])
    np.testing.assert_allclose(m.max_visible_range([0.0, 1.0]), [400.0, 400.0])
    # Out of range altogether: the vehicle is higher than the sensor reaches.
    assert not visibility_map(CITY, (1500.0, 1500.0), 600.0, 500.0).visible([1500.0, 1500.0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"target_xy": (0.0, np.nan)}, "target_xy"),
        ({"altitude_m": 0.0}, "altitude_m"),
        ({"altitude_m": 10.0, "target_height_m": 20.0}, "altitude_m"),
        ({"target_height_m": -1.0}, "target_height_m"),
        ({"max_range_m": 0.0}, "max_range_m"),
        ({"bins": 4}, "bins"),
    ],
)
def test_visibility_map_validates_its_arguments(kwargs: dict, message: str) -> None:
    arguments = {"target_xy": (100.0, 100.0), "altitude_m": 200.0, "max_range_m": 5000.0} | kwargs
    with pytest.raises(ValueError, match=message):
        visibility_map(CITY, **arguments)


def test_one_map_per_predicted_point() -> None:
    points = np.array([[1503.3, 1540.7], [1520.0, 1540.7], [1540.0, 1545.0]])
    maps = visibility_maps(CITY, points, 200.0, 5000.0)
    assert len(maps) == 3
    for m, p in zip(maps, points):
        np.testing.assert_array_equal(m.target_xyz, [p[0], p[1], 0.0])
    world = World(CITY, World.empty().airspace, STREETS, (3000.0, 3000.0))
    via_world = world.visibility_maps(points, 200.0, 5000.0)
    xy = np.random.default_rng(1).uniform(0, 3000, (2000, 2))
    for a, b in zip(maps, via_world):
        np.testing.assert_array_equal(a.visible(xy), b.visible(xy))


def test_non_finite_queries_are_not_visible() -> None:
    m = visibility_map(CITY, (1503.3, 1540.7), 200.0, 5000.0)
    assert m.visible([[np.nan, 1540.0], [1503.3, np.inf], [1503.3, 1540.7]]).tolist() == [False, False, True]


def test_stacked_maps_answer_like_each_map() -> None:
    rng = np.random.default_rng(21)
    points = STREETS.nearest_intersection(rng.uniform(0, 3000, (5, 2))) + rng.uniform(-14, 14, (5, 2))
    maps = visibility_maps(CITY, points, 200.0, 5000.0)
    low = visibility_map(CITY, points[0], 90.0, 700.0)  # altitudes and ranges may differ
    stacked = VisibilityMaps((*maps, low))
    assert len(stacked) == 6 and stacked[5] is low
    xy = points[0] + rng.normal(0.0, 600.0, (50, 3, 6, 2))  # e.g. population x vehicles x horizon
    got = stacked.visible(xy)
    assert got.shape == (50, 3, 6)
    for i, m in enumerate(stacked.maps):
        np.testing.assert_array_equal(got[..., i], m.visible(xy[..., i, :]))
        np.testing.assert_array_equal(got[..., i], _reference(m, xy[..., i, :]))
    assert got.any() and not got.all()
    with pytest.raises(ValueError, match="shape"):
        stacked.visible(xy[..., :5, :])
    with pytest.raises(ValueError, match="same Buildings"):
        VisibilityMaps((maps[0], visibility_map(STARS, (500.0, 500.0), 200.0, 5000.0)))


def test_maps_of_an_open_field_see_everything_within_range() -> None:
    from gcs.core.world import Buildings, VisibilityMaps, visibility_maps

    maps = VisibilityMaps(visibility_maps(Buildings.empty(), np.array([[0.0, 0.0], [100.0, 0.0]]), 100.0, 1000.0))
    seen = maps.visible(np.array([[[500.0, 0.0], [100.0, 2000.0]]]))
    assert seen.tolist() == [[True, False]]


@pytest.mark.parametrize(("altitude", "max_range", "target_height"), [(200.0, 5000.0, 0.0), (60.0, 900.0, 1.5)])
def test_sight_lines_answer_as_the_maps_do(altitude: float, max_range: float, target_height: float) -> None:
    """SightLines (no maps built, for planners that score one plan) gives the maps' answers exactly."""
    rng = np.random.default_rng(int(altitude))
    points = STREETS.nearest_intersection(rng.uniform(0, 3000, (5, 2))) + rng.uniform(-14, 14, (5, 2))
    maps = VisibilityMaps(visibility_maps(CITY, points, altitude, max_range, target_height_m=target_height))
    lines = World(CITY, World.empty().airspace, STREETS, (3000.0, 3000.0)).sight_lines(points, altitude, max_range,
                                                                                      target_height)
    xy = points + rng.normal(0.0, 500.0, (400, 3, 5, 2))  # e.g. population x vehicles x horizon
    xy[0, 0, 0] = (np.nan, 0.0)
    xy[0, 0, 1] = points[1]  # right above the target
    got = lines.visible(xy)
    assert got.shape == (400, 3, 5) and got.any() and not got.all()
    np.testing.assert_array_equal(got, maps.visible(xy))
    assert not got[0, 0, 0] and got[0, 0, 1]
    with pytest.raises(ValueError, match="shape"):
        lines.visible(xy[..., :4, :])
