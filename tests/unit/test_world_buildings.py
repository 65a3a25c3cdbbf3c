"""Buildings, the generated city and its streets, and GeoJSON footprints."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.core.world import Buildings, StreetGrid, buildings_from_geojson, generate_city
from gcs.core.world._polygons import signed_area

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
L_SHAPE = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, 20.0), (0.0, 20.0)]

CITY, STREETS = generate_city(np.random.default_rng(2012))


# --- Buildings -----------------------------------------------------------------------------


def test_from_polygons_stores_ccw_footprints_and_padded_edges() -> None:
    clockwise_triangle = [(0.0, 0.0), (0.0, 5.0), (5.0, 0.0)]
    b = Buildings.from_polygons([clockwise_triangle, L_SHAPE], [15.0, 30.0])
    assert len(b) == 2
    assert all(signed_area(f) > 0 for f in b.footprints)
    assert b.edges.shape == (2, 6, 2, 2)
    np.testing.assert_array_equal(b.edge_valid, [[True] * 3 + [False] * 3, [True] * 6])
    # Each edge ends where the next starts, and the last closes the ring.
    for index, footprint in enumerate(b.footprints):
        k = len(footprint)
        np.testing.assert_array_equal(b.edges[index, :k, 0], footprint)
        np.testing.assert_array_equal(b.edges[index, :k, 1], np.roll(footprint, -1, axis=0))
    np.testing.assert_array_equal(b.bbox, [[0.0, 0.0, 5.0, 5.0], [0.0, 0.0, 20.0, 20.0]])
    np.testing.assert_array_equal(b.heights, [15.0, 30.0])
    np.testing.assert_array_equal(b.convex, [True, False])


def test_closing_vertex_is_dropped_and_arrays_are_read_only() -> None:
    b = Buildings.from_polygons([[*SQUARE, SQUARE[0]]], [10.0])
    assert b.footprints[0].shape == (4, 2)
    with pytest.raises(ValueError):
        b.heights[0] = 5.0
    with pytest.raises(ValueError):
        b.edges[0, 0, 0, 0] = 1.0


@pytest.mark.parametrize(
    ("polygons", "heights", "message"),
    [
        ([SQUARE, [(0.0, 0.0), (1.0, 1.0)]], [10.0, 10.0], "polygon 1: needs at least 3 vertices"),
        ([SQUARE, [(0.0, 0.0), (1.0, np.nan), (1.0, 0.0)]], [10.0, 10.0], "polygon 1: vertices must be finite"),
        ([[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]], [10.0], "polygon 0: zero area"),
        ([SQUARE], [0.0], "polygon 0: height must be finite and > 0"),
        ([SQUARE], [-3.0], "polygon 0: height must be finite and > 0"),
        ([SQUARE], [np.inf], "polygon 0: height must be finite and > 0"),
        ([SQUARE, SQUARE], [10.0], "2 polygons but 1 heights"),
        ([[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0]]], [10.0], "polygon 0: vertices must have shape"),
    ],
)
def test_from_polygons_rejects_bad_input(polygons: list, heights: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Buildings.from_polygons(polygons, heights)


def test_contains_xy_uses_the_footprint_not_the_bounding_box() -> None:
    b = Buildings.from_polygons([L_SHAPE], [10.0])
    points = np.array([[[5.0, 5.0], [15.0, 5.0], [5.0, 15.0]], [[15.0, 15.0], [-1.0, 5.0], [25.0, 5.0]]])
    inside = b.contains_xy(points)
    assert inside.shape == (2, 3)
    np.testing.assert_array_equal(inside, [[True, True, True], [False, False, False]])


def test_empty_buildings() -> None:
    b = Buildings.empty()
    assert len(b) == 0
    assert b.contains_xy(np.zeros((3, 2))).tolist() == [False, False, False]


def test_from_boxes_matches_from_polygons() -> None:
    boxes = Buildings.from_boxes([[0.0, 0.0, 10.0, 10.0]], [7.0])
    polygons = Buildings.from_polygons([SQUARE], [7.0])
    np.testing.assert_array_equal(boxes.edges, polygons.edges)
    with pytest.raises(ValueError, match="xmin < xmax"):
        Buildings.from_boxes([[5.0, 0.0, 5.0, 10.0]], [7.0])


# --- Generated city ------------------------------------------------------------------------


def test_generated_city_matches_wang2012_section_5() -> None:
    assert len(CITY) == 400
    assert CITY.bbox[:, :2].min() >= 0.0 and CITY.bbox[:, 2:].max() <= 3000.0
    assert np.all((CITY.heights > 20.0) & (CITY.heights <= 120.0))
    # 20 x 20 blocks, a street on every block boundary including the city's edges.
    np.testing.assert_allclose(STREETS.xs, np.linspace(0.0, 3000.0, 21))
    np.testing.assert_allclose(STREETS.ys, np.linspace(0.0, 3000.0, 21))
    assert STREETS.width_m == 30.0 and STREETS.size_m == (3000.0, 3000.0)
    assert np.all(CITY.convex)


def _street_overlaps(buildings: Buildings, streets: StreetGrid) -> int:
    half = streets.width_m / 2
    box = buildings.bbox
    x_hit = (box[:, None, 0] < streets.xs + half) & (box[:, None, 2] > streets.xs - half)
    y_hit = (box[:, None, 1] < streets.ys + half) & (box[:, None, 3] > streets.ys - half)
    return int(x_hit.any(axis=1).sum() + y_hit.any(axis=1).sum())


def _building_overlaps(buildings: Buildings) -> int:
    a, b = buildings.bbox[:, None, :], buildings.bbox[None, :, :]
    overlap = (a[..., 0] < b[..., 2]) & (b[..., 0] < a[..., 2]) & (a[..., 1] < b[..., 3]) & (b[..., 1] < a[..., 3])
    return int(np.count_nonzero(overlap) - len(buildings))


def test_generated_buildings_stay_off_the_streets_and_apart() -> None:
    assert _street_overlaps(CITY, STREETS) == 0
    assert _building_overlaps(CITY) == 0


def test_generated_city_is_deterministic_by_seed() -> None:
    again, streets = generate_city(np.random.default_rng(2012))
    other, _ = generate_city(np.random.default_rng(2013))
    np.testing.assert_array_equal(again.edges, CITY.edges)
    np.testing.assert_array_equal(again.heights, CITY.heights)
    np.testing.assert_array_equal(streets.xs, STREETS.xs)
    assert not np.array_equal(other.edges, CITY.edges)


@pytest.mark.parametrize(
    ("size", "count", "width"),
    [((3000.0, 3000.0), 37, 30.0), ((2000.0, 1000.0), 50, 20.0), ((1000.0, 1000.0), 3000, 30.0),
     ((500.0, 800.0), 1, 0.0), ((3000.0, 3000.0), 0, 30.0)],
)
def test_generated_city_other_sizes(size: tuple[float, float], count: int, width: float) -> None:
    buildings, streets = generate_city(np.random.default_rng(7), size_m=size, buildings=count,
                                       street_width_m=width, min_height_m=5.0, max_height_m=50.0)
    assert len(buildings) == count
    assert _street_overlaps(buildings, streets) == 0
    assert _building_overlaps(buildings) == 0
    if count:
        assert buildings.bbox[:, :2].min() >= 0.0
        assert np.all(buildings.bbox[:, 2:] <= np.array(size))


def test_generate_city_rejects_impossible_parameters() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="street_width_m"):
        generate_city(rng, size_m=(100.0, 100.0), street_width_m=150.0)
    with pytest.raises(ValueError, match="min_height_m"):
        generate_city(rng, min_height_m=50.0, max_height_m=10.0)
    with pytest.raises(ValueError, match="buildings"):
        generate_city(rng, buildings=-1)


@settings(max_examples=200)
@given(st.integers(0, 20), st.floats(0.0, 3000.0), st.floats(-15.0, 15.0), st.booleans())
def test_points_on_street_centre_lines_are_on_streets(index: int, along: float, across: float, ns: bool) -> None:
    point = (STREETS.xs[index] + across, along) if ns else (along, STREETS.ys[index] + across)
    assert STREETS.on_street(point)
    assert not CITY.contains_xy(point)


def test_points_inside_buildings_are_not_on_streets() -> None:
    rng = np.random.default_rng(3)
    box = CITY.bbox
    t = rng.uniform(0.01, 0.99, size=(len(box), 2))
    inside = np.stack([box[:, 0] + t[:, 0] * (box[:, 2] - box[:, 0]), box[:, 1] + t[:, 1] * (box[:, 3] - box[:, 1])], -1)
    assert CITY.contains_xy(inside).all()
    assert not STREETS.on_street(inside).any()
    assert not STREETS.on_street([[-100.0, 1500.0], [1500.0, 3100.0]]).any()


def test_nearest_intersection() -> None:
    got = STREETS.nearest_intersection([[74.0, 76.0], [2990.0, -20.0], [1510.0, 1649.0]])
    np.testing.assert_array_equal(got, [[0.0, 150.0], [3000.0, 0.0], [1500.0, 1650.0]])


# --- GeoJSON ---------------------------------------------------------------------------------


def _feature(geometry: dict, **properties: object) -> dict:
    return {"type": "Feature", "geometry": geometry, "properties": properties}


def _collection(*features: dict) -> dict:
    return {"type": "FeatureCollection", "features": list(features)}


def test_geojson_polygons_and_multipolygons_round_trip() -> None:
    clockwise_closed = [[0.0, 0.0], [0.0, 10.0], [10.0, 10.0], [10.0, 0.0], [0.0, 0.0]]
    hole = [[2.0, 2.0], [4.0, 2.0], [4.0, 4.0], [2.0, 2.0]]
    doc = _collection(
        _feature({"type": "Polygon", "coordinates": [clockwise_closed, hole]}, height=25),
        _feature({"type": "MultiPolygon", "coordinates": [[[[20, 0], [30, 0], [30, 5], [20, 0]]],
                                                          [[[40, 0], [50, 0], [45, 8]]]]}, height=12.5, name="x"),
    )
    b = buildings_from_geojson(doc)
    assert len(b) == 3
    np.testing.assert_array_equal(b.heights, [25.0, 12.5, 12.5])
    assert all(signed_area(f) > 0 for f in b.footprints)
    assert set(map(tuple, b.footprints[0].tolist())) == {(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)}
    np.testing.assert_array_equal(b.footprints[2], [[40.0, 0.0], [50.0, 0.0], [45.0, 8.0]])
    # The hole is ignored: its centre is inside the building.
    assert b.contains_xy([3.0, 2.5])


def test_geojson_converts_lon_lat_with_the_given_function() -> None:
    doc = _collection(_feature({"type": "Polygon", "coordinates": [[[1, 1], [2, 1], [2, 3], [1, 1]]]}, h=9))
    b = buildings_from_geojson(doc, height_property="h", to_enu=lambda lon, lat: (100.0 * lon, 10.0 * lat))
    np.testing.assert_allclose(b.footprints[0], [[100.0, 10.0], [200.0, 10.0], [200.0, 30.0]])


@pytest.mark.parametrize(
    ("features", "message"),
    [
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]})],
         "feature 0: missing property 'height'"),
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}, height=5),
          _feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}, height="tall")],
         "feature 1: property 'height' must be a number"),
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}, height=True)],
         "feature 0: property 'height' must be a number"),
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}, height=-2)],
         "feature 0: property 'height' must be finite and > 0"),
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 0]]]}, height=5)],
         "feature 0: needs at least 3 vertices"),
        ([_feature({"type": "Point", "coordinates": [0, 0]}, height=5)],
         "feature 0: geometry type 'Point' is not supported"),
        ([_feature({"type": "MultiPolygon", "coordinates": [[[[0, 0], [1, 0], [1, 1]]], [[[0, 0], [1, 1]]]]},
                   height=5)], "feature 0 polygon 1: needs at least 3 vertices"),
        ([_feature({"type": "Polygon", "coordinates": [[[0, 0], ["a", 0], [1, 1]]]}, height=5)],
         "feature 0: coordinates must be"),
    ],
)
def test_geojson_errors_name_the_feature(features: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        buildings_from_geojson(_collection(*features))


def test_geojson_must_be_a_feature_collection() -> None:
    with pytest.raises(ValueError, match="FeatureCollection"):
        buildings_from_geojson({"type": "Feature"})
    assert len(buildings_from_geojson(_collection())) == 0
