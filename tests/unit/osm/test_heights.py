"""Roof heights from OSM tags: units, levels, the default, and what is not understood."""

from __future__ import annotations

import pytest

from gcs.adapters.osm.heights import DEFAULT_HEIGHT_M, METRES_PER_LEVEL, building_height, parse_height, parse_levels


@pytest.mark.parametrize(("text", "metres"), [
    ("12", 12.0), ("12.5", 12.5), (" 12.13 m", 12.13), ("48.5m", 48.5), ("7 metres", 7.0), (".5", 0.5),
    ("40 ft", 12.192), ("40'", 12.192), ("40'6\"", 12.3444), ("10 feet", 3.048),
])
def test_heights_in_metres_or_feet(text: str, metres: float) -> None:
    assert parse_height(text) == pytest.approx(metres, abs=1e-9)


@pytest.mark.parametrize("text", [None, "", "tall", "12 km", "12;15", "-3", "0", "1500", "12,5", "about 10"])
def test_heights_not_understood(text: str | None) -> None:
    assert parse_height(text) is None


@pytest.mark.parametrize(("text", "levels"), [("4", 4.0), ("2.5", 2.5), (" 7 ", 7.0), ("0", None), ("-1", None),
                                              ("3-4", None), ("nan", None), ("inf", None), ("250", None)])
def test_levels(text: str, levels: float | None) -> None:
    assert parse_levels(text) == levels


def test_the_first_rule_that_applies_gives_the_height() -> None:
    assert building_height({"height": "21", "building:levels": "3"}) == (21.0, "height")
    assert building_height({"height": "tall", "building:levels": "3"}) == (3 * METRES_PER_LEVEL, "building:levels")
    assert building_height({"building:levels": "2.5"}) == (7.5, "building:levels")
    assert building_height({"building": "yes"}) == (DEFAULT_HEIGHT_M, "default")
    assert building_height({"building:levels": "lots"}, default_height_m=9.0) == (9.0, "default")
    assert METRES_PER_LEVEL == 3.0 and DEFAULT_HEIGHT_M == 15.0
