"""The sight table against the exact line of sight, and its height field against the footprints."""

from __future__ import annotations

import numpy as np

from gcs.config.world import build_world
from gcs.core.world import World
from gcs.core.world.buildings import Buildings
from gcs.core.world.sight_table import HeightField, SightTable
from gcs.scenarios import load_scenario

WORLD = build_world(load_scenario("wang2012_urban"))
DOWNTOWN = build_world(load_scenario("downtown_dense"))


def test_height_field_holds_each_cell_centre_s_roof() -> None:
    buildings = Buildings.from_boxes([[10.3, 10.3, 30.3, 20.3], [25.3, 15.3, 40.3, 40.3]], [50.0, 80.0])
    field = HeightField.from_buildings(buildings, cell_m=2.0, margin_m=10.0)
    rng = np.random.default_rng(1)
    points = rng.uniform(-5.0, 55.0, (2000, 2))
    i, j = field.cells(points)
    centres = np.stack([field.origin_xy[0] + (i + 0.5) * 2.0, field.origin_xy[1] + (j + 0.5) * 2.0], axis=-1)
    x, y = centres[:, 0], centres[:, 1]
    inside_tall = (x > 25.3) & (x < 40.3) & (y > 15.3) & (y < 40.3)
    inside_low = (x > 10.3) & (x < 30.3) & (y > 10.3) & (y < 20.3)
    expected = np.where(inside_tall, 80.0, np.where(inside_low, 50.0, 0.0))  # the taller wins where they overlap
    assert np.array_equal(field.at(points), expected)
    assert field.at(np.array([[1e6, 1e6]]))[0] == 0.0  # off the grid: open ground


def _agreement(world: World, altitude_m: float, seed: int, radius_m: float) -> tuple[float, float]:
    """Share of (street point, vehicle) pairs on which the table and the exact test agree, and the exact
    visible share, for vehicles within ``radius_m`` of points on the street centre lines."""
    table = SightTable(HeightField.from_buildings(world.buildings), 200.0, reach_m=600.0)
    rng = np.random.default_rng(seed)
    streets = world.streets
    along = rng.uniform(300.0, min(world.size_m) - 300.0, 400)
    on_x = rng.random(400) < 0.5
    targets = np.where(on_x[:, None], np.stack([rng.choice(streets.xs[1:-1], 400), along], 1),
                       np.stack([along, rng.choice(streets.ys[1:-1], 400)], 1))
    offsets = rng.uniform(-radius_m, radius_m, (400, 16, 2))
    vehicles = targets[:, None, :] + offsets
    inverse = table.inverse_slopes(targets)
    dx, dy = offsets[..., 0], offsets[..., 1]
    distance = np.hypot(dx, dy)
    table_says = distance * np.take_along_axis(inverse, table.bin_of(dx, dy), axis=1) <= altitude_m
    exact = world.line_of_sight(np.concatenate([np.broadcast_to(targets[:, None], vehicles.shape),
                                                np.zeros(vehicles.shape[:-1] + (1,))], axis=-1),
                                np.concatenate([vehicles, np.full(vehicles.shape[:-1] + (1,), altitude_m)], axis=-1))
    return float(np.mean(table_says == exact)), float(np.mean(exact))


def test_table_agrees_with_the_exact_line_of_sight_in_both_cities() -> None:
    for world, share in ((WORLD, 0.96), (DOWNTOWN, 0.96)):
        agree, visible = _agreement(world, 200.0, 5, 400.0)
        assert agree >= share, (agree, visible)
        assert 0.1 < visible < 0.9  # a test of sight and of occlusion both


def test_one_table_serves_every_altitude() -> None:
    agree_low, _ = _agreement(WORLD, 200.0, 6, 300.0)
    agree_high, _ = _agreement(WORLD, 260.0, 6, 300.0)
    assert agree_low >= 0.96 and agree_high >= 0.96


def test_a_wall_hides_what_is_behind_it_and_the_memo_changes_nothing() -> None:
    # A 190 m wall 10 m west of the point: from 200 m a vehicle sees past it only within 10 * 200 / 190 m.
    wall = Buildings.from_boxes([[990.0, 0.0, 1000.0, 2000.0]], [190.0])
    table = SightTable(HeightField.from_buildings(wall, cell_m=2.0, margin_m=700.0), 200.0)
    point = np.array([[1010.0, 1000.0]])
    first = table.inverse_slopes(point)
    vehicles = np.array([[1200.0, 1000.0], [1010.0, 1200.0], [1005.0, 1000.0], [800.0, 1000.0], [980.0, 1000.0]])
    dx, dy = vehicles[:, 0] - 1010.0, vehicles[:, 1] - 1000.0
    seen = np.hypot(dx, dy) * first[0, table.bin_of(dx, dy)] <= 200.0
    assert seen.tolist() == [True, True, True, False, False]
    assert table.nodes == 1
    again = table.inverse_slopes(np.array([[1010.4, 999.7], [1010.0, 1000.0]]))  # the same lattice node
    assert table.nodes == 1 and np.array_equal(again[0], first[0]) and np.array_equal(again[1], first[0])


def test_points_beyond_the_grid_see_past_the_city_s_edge_and_open_sky_farther_out() -> None:
    """Ground points 20-800 m outside the city's grid (clutter lands there): the table agrees with the exact
    test on at least 98% of their sight lines to vehicles within 1 km, and a point beyond every roof's reach
    sees every vehicle in the sky."""
    table = SightTable(HeightField.from_buildings(WORLD.buildings), 200.0, reach_m=600.0)
    rng = np.random.default_rng(3)
    size = min(WORLD.size_m)
    side, out, along = rng.integers(4, size=400), rng.uniform(20.0, 800.0, 400), rng.uniform(0.0, size, 400)
    targets = np.select([side[:, None] == 0, side[:, None] == 1, side[:, None] == 2],
                        [np.stack([-out, along], 1), np.stack([size + out, along], 1), np.stack([along, -out], 1)],
                        np.stack([along, size + out], 1))
    offsets = rng.uniform(-1000.0, 1000.0, (400, 16, 2))
    vehicles = targets[:, None, :] + offsets
    inverse = table.inverse_slopes(targets)
    dx, dy = offsets[..., 0], offsets[..., 1]
    table_says = np.hypot(dx, dy) * np.take_along_axis(inverse, table.bin_of(dx, dy), axis=1) <= 200.0
    exact = WORLD.line_of_sight(np.concatenate([np.broadcast_to(targets[:, None], vehicles.shape),
                                                np.zeros(vehicles.shape[:-1] + (1,))], axis=-1),
                                np.concatenate([vehicles, np.full(vehicles.shape[:-1] + (1,), 200.0)], axis=-1))
    assert np.mean(table_says == exact) >= 0.98
    assert 0.5 < np.mean(exact) < 1.0  # mostly open ground, some sight lines across the city's edge
    far = table.inverse_slopes(np.array([[-5000.0, 1500.0], [size + 2000.0, size + 2000.0]]))
    assert not far.any()
