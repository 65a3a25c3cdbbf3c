"""Restricted airspace (wang2012 eq. 5): inside the polygon and within the altitude band."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.config import RestrictedAirspace as ZoneConfig
from gcs.config import ScenarioError
from gcs.config.world import airspace_from_config
from gcs.core.world import RestrictedAirspace

SQUARE = [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)]
L_ZONE = [(200.0, 0.0), (400.0, 0.0), (400.0, 100.0), (300.0, 100.0), (300.0, 200.0), (200.0, 200.0)]

AIRSPACE = RestrictedAirspace.from_zones([(SQUARE, 100.0, 300.0), (L_ZONE[::-1], 0.0, 150.0)], names=["tower", "base"])


@pytest.mark.parametrize(
    ("point", "inside"),
    [
        ((50.0, 50.0, 200.0), True),
        ((50.0, 50.0, 100.0), True),  # the band is closed
        ((50.0, 50.0, 300.0), True),
        ((50.0, 50.0, 99.9), False),  # below the floor
        ((50.0, 50.0, 300.1), False),  # above the ceiling
        ((150.0, 50.0, 200.0), False),  # outside both polygons
        ((250.0, 150.0, 50.0), True),  # in the L's upright
        ((350.0, 150.0, 50.0), False),  # in the L's notch
        ((350.0, 50.0, 149.0), True),
        ((350.0, 50.0, 151.0), False),
        ((-1.0, 50.0, 200.0), False),
    ],
)
def test_inside_polygon_and_band(point: tuple[float, float, float], inside: bool) -> None:
    assert bool(AIRSPACE.inside(point)) is inside


def test_inside_is_vectorised_and_keeps_shape() -> None:
    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(-50, 450, (40, 2)), rng.uniform(0, 400, 40)].reshape(4, 10, 3)
    result = AIRSPACE.inside(points)
    assert result.shape == (4, 10)
    expected = [[bool(AIRSPACE.inside(p)) for p in row] for row in points]
    np.testing.assert_array_equal(result, expected)
    assert result.any() and not result.all()


@given(st.floats(0.5, 99.5), st.floats(0.5, 99.5), st.floats(-100.0, 500.0))
def test_square_zone_matches_its_definition(x: float, y: float, z: float) -> None:
    assert bool(AIRSPACE.inside((x, y, z))) == (100.0 <= z <= 300.0)


def test_empty_airspace_restricts_nothing() -> None:
    empty = RestrictedAirspace.empty()
    assert len(empty) == 0
    assert not empty.inside(np.zeros((5, 3))).any()


@pytest.mark.parametrize(
    ("zones", "message"),
    [
        ([(SQUARE, 300.0, 100.0)], "zone 0: floor_m .* must be below ceiling_m"),
        ([(SQUARE, 100.0, 100.0)], "zone 0: floor_m"),
        ([(SQUARE, 0.0, 10.0), (SQUARE[:2], 0.0, 10.0)], "zone 1: needs at least 3 vertices"),
    ],
)
def test_bad_zones_are_named(zones: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        RestrictedAirspace.from_zones(zones)


def test_from_scenario_config() -> None:
    zones = [ZoneConfig(name="hospital", polygon_enu_m=[(0.0, 0.0), (50.0, 0.0), (50.0, 50.0)], floor_m=0.0,
                        ceiling_m=500.0)]
    airspace = airspace_from_config(zones)
    assert airspace.names == ("hospital",)
    assert airspace.inside((40.0, 10.0, 200.0)) and not airspace.inside((10.0, 40.0, 200.0))
    flat = [ZoneConfig(name="flat", polygon_enu_m=[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)])]
    with pytest.raises(ScenarioError, match="restricted.*flat: zero area"):
        airspace_from_config(flat)
