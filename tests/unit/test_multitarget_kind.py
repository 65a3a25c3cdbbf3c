"""``[multitarget] kind``: ``auto`` is the road tracker wherever the world has a road graph and the Gaussian tracker
elsewhere (as ``[estimator] kind = "auto"`` is for one target), ``gaussian`` is kept where there are roads, and
``road`` without roads is refused, naming the key."""

from __future__ import annotations

import pytest

from gcs.config import ScenarioError
from gcs.config.world import build_world
from gcs.core.multitarget import MultiTargetTracker
from gcs.core.multitarget.road_tracker import RoadMultiTargetTracker
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.multitarget import many_target_tracker
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import parse_scenario
from tests.unit.test_road_estimator_config import CITY
from tests.unit.test_scenarios import MINIMAL

MULTITARGET = """
[planner]
kind = "sight"
[multitarget]
association = "gnn"
"""


def _scenario(city: str = "generated", multitarget: str = "", extra: str = ""):
    """A 600 m city (``generated``: with its street grid; ``empty``: no roads) with ``[multitarget]``."""
    return parse_scenario(MINIMAL.decode() + CITY.format(city=city) + MULTITARGET + multitarget + "\n" + extra)


def _built(scenario, world=None):
    return many_target_tracker(scenario, world, tracker_config(scenario, world, "sight"))


def test_auto_is_the_road_tracker_in_a_city_with_roads_and_the_gaussian_one_elsewhere() -> None:
    generated, empty = _scenario("generated"), _scenario("empty")
    assert generated.multitarget.kind == empty.multitarget.kind == "auto"
    world = build_world(generated)
    road = Engine(generated, world, EngineOptions()).keeper.tracker
    assert isinstance(road, RoadMultiTargetTracker) and road.roads.graph is world.roads
    assert road.association == "gnn" and road.particles == 200 and road.sees is not None
    plain = Engine(empty, build_world(empty), EngineOptions()).keeper.tracker
    assert type(plain) is MultiTargetTracker and plain.association == "gnn"


def test_the_road_tracker_moves_as_estimator_road_says_and_takes_its_seed() -> None:
    scenario = _scenario(multitarget="road_particles = 50",
                         extra="[estimator.road]\nturn_probability = 0.2\nseed = 7\nspread_m = 5.0\n")
    road = _built(scenario, build_world(scenario))
    assert (road.particles, road.seed) == (50, 7)
    assert (road.roads.turn_probability, road.roads.spread_m) == (0.2, 5.0)


def test_gaussian_is_kept_where_there_are_roads() -> None:
    scenario = _scenario(multitarget='kind = "gaussian"')
    assert type(_built(scenario, build_world(scenario))) is MultiTargetTracker


def test_auto_without_a_world_is_the_gaussian_tracker_and_road_needs_the_world() -> None:
    """Estimation without a world (every track covered) runs the Gaussian tracker; ``road`` asked for by name
    needs the world's roads."""
    duif = '[estimator]\nkind = "duif"\n'  # the single-target road tracker needs the world too
    assert type(_built(_scenario(extra=duif))) is MultiTargetTracker
    with pytest.raises(ValueError, match="needs the world's road graph"):
        _built(_scenario(multitarget='kind = "road"', extra=duif))


def test_road_without_roads_is_refused_naming_the_key() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.multitarget\.kind: 'road' needs a road graph"):
        _scenario("empty", 'kind = "road"')
    with pytest.raises(ScenarioError, match=r"\$\.multitarget\.road_particles"):
        _scenario(multitarget="road_particles = 1")
    assert _scenario("empty", 'kind = "gaussian"').multitarget.kind == "gaussian"
