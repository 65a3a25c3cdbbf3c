"""The paper's GA plans with visibility regions built at the lowest UAV's altitude (wang2012 eq. 22).

A region computed higher up is larger (a higher line of sight clears more roofs), so maps built at the
highest UAV's altitude would promise the lower UAVs sight they do not have. The team of the default
scenario flies at 200, 210 and 220 m.
"""

from __future__ import annotations

import numpy as np

from gcs.config.world import build_world
from gcs.core.world.visibility import VisibilityMaps
from gcs.scenarios import load_scenario
from gcs.engine.tracker_factory import tracker_config

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
POINTS = np.array([[1500.0, 1500.0], [1200.0, 1800.0], [2400.0, 900.0]])
"""Predicted target points: the target's start and two more inside the city."""


def test_the_ga_builds_its_maps_at_the_lowest_uav_altitude_not_the_highest() -> None:
    altitudes = sorted({v.altitude_m for v in SCENARIO.vehicles})
    assert altitudes[0] < altitudes[-1]  # the team flies at different heights: the choice matters
    maps = tracker_config(SCENARIO, WORLD, "ga_k5").visibility(POINTS)
    assert [m.altitude_m for m in maps.maps] == [altitudes[0]] * len(POINTS)


def test_the_lowest_altitude_gives_other_answers_than_the_highest() -> None:
    """The test above can fail: from some positions a UAV at 220 m sees a point that one at 200 m does not."""
    maps = tracker_config(SCENARIO, WORLD, "ga_k5").visibility(POINTS)
    low = [m.altitude_m for m in maps.maps][0]
    high = max(v.altitude_m for v in SCENARIO.vehicles)
    rng = np.random.default_rng(4)
    positions = np.repeat(rng.uniform(0.0, 3000.0, size=(4000, 1, 2)), len(POINTS), axis=1)  # each map asked
    at_high = VisibilityMaps(WORLD.visibility_maps(POINTS, high, maps.maps[0].max_range_m))
    seen_low, seen_high = maps.visible(positions), at_high.visible(positions)
    assert low < high and np.any(seen_high & ~seen_low)
    assert not np.any(seen_low & ~seen_high)  # higher never sees less
