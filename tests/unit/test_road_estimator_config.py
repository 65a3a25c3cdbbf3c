"""``[estimator]`` and the road tracker: ``auto`` is the road tracker wherever the world has a road graph, explicit
kinds are kept, the shipped scenarios whose target is no car name theirs, and bad values name their key."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from gcs.config import ScenarioError, estimator_kind
from gcs.config.world import build_world
from gcs.core.roads import RoadParticleFilter
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import list_scenarios, load_scenario, parse_scenario
from tests.unit.test_scenarios import MINIMAL

CITY = """
[city]
kind = "{city}"
size_m = [600.0, 600.0]
buildings = 9
[target]
start_enu_m = [300.0, 300.0]
"""


def _scenario(city: str = "generated", extra: str = ""):
    return parse_scenario(MINIMAL.decode() + CITY.format(city=city) + extra)


def test_auto_is_the_road_tracker_in_a_city_with_roads_and_the_duif_elsewhere() -> None:
    generated, empty = _scenario("generated"), _scenario("empty")
    assert generated.estimator.kind == empty.estimator.kind == "auto"
    assert (estimator_kind(generated), estimator_kind(empty)) == ("road", "duif")
    world = build_world(generated)
    with_roads = tracker_config(generated, world, "sight")
    without = tracker_config(empty, build_world(empty), "sight")
    assert with_roads.road is not None and with_roads.road.filter.graph is world.roads
    assert without.road is None and without.bearing_filter is None and without.target_imm is None


def test_the_road_tracker_of_the_defaults_is_the_filter_at_its_class_defaults() -> None:
    scenario = _scenario()
    world = build_world(scenario)
    road = tracker_config(scenario, world, "sight").road
    reference = RoadParticleFilter(world.roads)
    for name in ("particles", "speed_psd_m2_s3", "max_speed_mps", "turn_probability", "leave_rate_per_s",
                 "rejoin_rate_per_s", "rejoin_m", "off_road_psd_m2_s3", "spread_m", "initial_off_road"):
        assert getattr(road.filter, name) == getattr(reference, name), name
    assert road.sees is not None and road.detection_probability == 0.9


def test_explicit_kinds_are_kept_where_there_are_roads() -> None:
    for kind in ("duif", "imm", "road"):
        scenario = _scenario(extra=f'[estimator]\nkind = "{kind}"\n')
        assert estimator_kind(scenario) == kind
        config = tracker_config(scenario, build_world(scenario), "orbit")
        assert (config.road is not None) == (kind == "road")
        assert (config.target_imm is not None) == (kind == "imm")


def test_road_parameters_reach_the_filter() -> None:
    scenario = _scenario(extra="[estimator.road]\nparticles = 123\nturn_probability = 0.3\n"
                               "off_road_rate_per_s = 0.05\ndetection_probability = 0.0\nseed = 9\n")
    road = tracker_config(scenario, build_world(scenario), "sight").road
    assert (road.filter.particles, road.filter.turn_probability, road.filter.leave_rate_per_s) == (123, 0.3, 0.05)
    assert road.seed == 9
    assert road.looks(np.zeros((1, 3)), np.array([False])) is None  # P_D = 0: no negative information


def test_the_shipped_scenarios_whose_target_is_no_car_name_their_estimator() -> None:
    for name in list_scenarios():
        scenario = load_scenario(name)
        if scenario.target.motion != "streets":
            assert scenario.estimator.kind != "auto", name
    # the paper reproductions keep the paper's filter; the cars in cities get the road tracker
    kinds = {name: estimator_kind(load_scenario(name)) for name in list_scenarios()}
    assert kinds["wang2012_urban"] == "duif" and kinds["zuo2021_aoa"] == "vgukf"
    assert {kinds[n] for n in ("downtown_dense", "fast_target", "nofly_city", "helsinki_centre")} == {"road"}


@pytest.mark.parametrize(("extra", "key"), [
    ('[estimator]\nkind = "roads"\n', "$.estimator.kind"),
    ("[estimator.road]\nparticles = 1\n", "$.estimator.road.particles"),
    ("[estimator.road]\nturn_probability = 1.5\n", "$.estimator.road.turn_probability"),
    ("[estimator.road]\ndetection_probability = 1.0\n", "$.estimator.road.detection_probability"),
    ("[estimator.road]\noff_road_rate_per_s = -0.1\n", "$.estimator.road.off_road_rate_per_s"),
    ("[estimator.road]\nwheels = 4\n", "$.estimator.road"),
    ('[estimator]\nmodel = "ca2d"\n', "$.estimator.model"),
])
def test_bad_values_name_the_key(extra: str, key: str) -> None:
    with pytest.raises(ScenarioError, match=key.replace("$", r"\$").replace(".", r"\.").replace("[", r"\[")):
        _scenario(extra=extra)


def test_a_road_tracker_needs_roads() -> None:
    with pytest.raises(ScenarioError, match=r"\$\.estimator\.kind: 'road' needs a road graph"):
        _scenario("empty", '[estimator]\nkind = "road"\n')
    _scenario("empty", '[estimator]\nmodel = "ca2d"\n')  # auto without roads is the DUIF, which takes ca2d
    scenario = _scenario()
    with pytest.raises(ValueError, match="needs the world's road graph"):
        tracker_config(scenario, None, "sight")
    assert tracker_config(msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(
        scenario.estimator, kind="duif")), None, "sight").road is None
