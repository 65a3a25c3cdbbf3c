"""``gcs scenario from-osm`` on the small extract of :mod:`tests.unit.osm.extract`, in both formats.

Every figure is worked out by hand from the extract's drawing: which buildings and
roads are kept, their heights and lengths, the one-way edges, the attribution.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from gcs.cli import main
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.scenarios import load_scenario
from tests.unit.osm.extract import BOX_M, EXPECTED, NEWEST, ORIGIN, box_degrees, lon_lat, write_pbf, write_xml

BOX = ",".join(repr(v) for v in box_degrees())


def _build(tmp_path: Path, kind: str, *extra: str) -> Path:
    source = write_xml(tmp_path / "town.osm") if kind == "xml" else write_pbf(tmp_path / "town.osm.pbf")
    out = tmp_path / "town.toml"
    assert main(["scenario", "from-osm", str(source), f"--bbox={BOX}", "--out", str(out), *extra]) == 0
    return out


@pytest.fixture(scope="module", params=["xml", "pbf"])
def town(request, tmp_path_factory) -> Path:
    return _build(tmp_path_factory.mktemp(request.param), request.param)


def _features(path: Path) -> list[dict]:
    return json.loads(path.read_text())["features"]


def test_buildings_their_heights_and_the_box_edge(town: Path) -> None:
    features = _features(town.with_name("town_buildings.geojson"))
    found = {f["properties"]["osm_id"]: (f["properties"]["height"], f["properties"]["height_source"]) for f in features}
    # w206 (centroid beyond the edge), w207 (building=no) and w208 (a building:part) are left out
    assert found.keys() == EXPECTED.heights.keys()
    for osm_id, (height, source) in EXPECTED.heights.items():
        assert found[osm_id] == (pytest.approx(height, abs=0.005), source), osm_id
    # w205 crosses the box's east edge (x = 250 m) with its centroid inside: kept whole, to x = 275 m
    (w205,) = [f for f in features if f["id"] == "w205"]
    east = max(p[0] for p in w205["geometry"]["coordinates"][0])
    assert east == pytest.approx(lon_lat(275.0, 150.0)[0], abs=1e-7) and east > box_degrees()[2]
    # the relation is one building: its outer ring, the courtyard left out
    (r301,) = [f for f in features if f["id"] == "r301"]
    assert r301["geometry"]["type"] == "Polygon" and len(r301["geometry"]["coordinates"]) == 1
    world = build_world(load_scenario(town), town.parent)
    assert len(world.buildings) == len(EXPECTED.heights)
    assert sorted(world.buildings.heights) == pytest.approx(sorted(h for h, _ in EXPECTED.heights.values()), abs=0.005)


def test_roads_run_junction_to_junction_and_leave_out_what_a_car_may_not_drive(town: Path) -> None:
    features = _features(town.with_name("town_roads.geojson"))
    lengths = sorted(f["properties"]["length_m"] for f in features)
    assert lengths == pytest.approx(sorted(EXPECTED.road_lengths_m), abs=0.05)
    used = {way for f in features for way in f["properties"]["osm_ways"]}
    assert used.isdisjoint(EXPECTED.excluded_ways)  # the one-way that leaves the box, footway, private, service
    oneway = [f for f in features if f["properties"]["oneway"] == "yes"]
    assert len(oneway) == EXPECTED.oneway_edges
    # both one-way edges run north (B -> E -> H), as drawn
    for feature in oneway:
        (_, lat0), (_, lat1) = feature["geometry"]["coordinates"][0], feature["geometry"]["coordinates"][-1]
        assert lat1 > lat0


def test_the_world_graph_is_strongly_connected_and_keeps_one_way_streets(town: Path) -> None:
    world = build_world(load_scenario(town), town.parent)
    graph = world.roads
    assert graph is not None
    assert graph.total_length_m == pytest.approx(sum(EXPECTED.road_lengths_m), rel=1e-3)
    arcs = coo_matrix((np.ones(len(graph)), (graph.tail, graph.head)), shape=(len(graph.nodes),) * 2)
    count, _ = connected_components(arcs, directed=True, connection="strong")
    assert count == 1
    # B (100, 0) -> E (100, 100) is drivable north only; the cut stub ends at the box's edge, x = 250 m
    frame = LocalFrame(*_origin(town), 0.0)
    b, e = (_node_near(graph, frame, xy) for xy in ((100.0, 0.0), (100.0, 100.0)))
    pairs = set(zip(graph.tail.tolist(), graph.head.tolist()))
    assert (b, e) in pairs and (e, b) not in pairs
    east_end = graph.nodes[:, 0].max() - frame.to_enu(ORIGIN[0], ORIGIN[1], 0.0)[0]
    assert east_end == pytest.approx(BOX_M[2], abs=0.05)


def _origin(town: Path) -> tuple[float, float]:
    origin = tomllib.loads(town.read_text())["origin"]
    return origin["lat_deg"], origin["lon_deg"]


def _enu_offset(town: Path) -> np.ndarray:
    """Where the extract's own origin (its point (0, 0)) lies in the scenario's frame."""
    return LocalFrame(*_origin(town), 0.0).to_enu(ORIGIN[0], ORIGIN[1], 0.0)[:2]


def _node_near(graph, frame: LocalFrame, xy: tuple[float, float]) -> int:
    lon, lat = lon_lat(*xy)
    target = frame.to_enu(lat, lon, 0.0)[:2]
    distance = np.hypot(*(graph.nodes - target).T)
    assert distance.min() < 0.05
    return int(distance.argmin())


def test_attribution_origin_and_the_car(town: Path) -> None:
    document = tomllib.loads(town.read_text())
    source = document["source"]
    extract = next(town.parent.glob("town.osm*"))
    assert source["attribution"] == "© OpenStreetMap contributors" and source["licence"] == "ODbL-1.0"
    assert source["file"] == extract.name
    assert source["sha256"] == hashlib.sha256(extract.read_bytes()).hexdigest()
    assert source["data_date"] == f"{NEWEST} (newest element)"
    assert source["command"].startswith(f"gcs scenario from-osm {extract.name} --bbox=")
    for name in ("town_buildings.geojson", "town_roads.geojson"):
        head = json.loads(town.with_name(name).read_text())
        assert head["attribution"] == "© OpenStreetMap contributors" and head["license"] == "ODbL-1.0"
        assert extract.name in head["source"]
    west, south, east, north = box_degrees()
    assert _origin(town) == (pytest.approx((south + north) / 2, abs=1e-7), pytest.approx((west + east) / 2, abs=1e-7))
    scenario = load_scenario(town)
    assert scenario.target.motion == "streets" and scenario.target.street_speed_mps == 8.0
    # the car starts on a junction of the town: E (100, 100) is the one nearest the box's centre (100, 100)
    assert np.hypot(*(np.array(scenario.target.start_enu_m) - (np.array([100.0, 100.0]) + _enu_offset(town)))) < 0.1


def test_origin_and_default_height_options(tmp_path: Path) -> None:
    town = _build(tmp_path, "xml", "--origin", f"{ORIGIN[0]},{ORIGIN[1]}", "--default-height", "9.5")
    assert _origin(town) == ORIGIN
    heights = {f["properties"]["osm_id"]: f["properties"]["height"] for f in _features(town.with_name("town_buildings.geojson"))}
    assert heights["w204"] == 9.5 and heights["w201"] == 12.0
    assert "--default-height 9.5" in tomllib.loads(town.read_text())["source"]["command"]
    world = build_world(load_scenario(town), town.parent)
    # about the extract's own origin, A (0, 0) is a node of the graph and the buildings lie where they were drawn
    assert np.hypot(*world.roads.nodes.T).min() < 0.05
    assert world.buildings.contains_xy([[27.5, 50.0], [150.0, 67.5], [50.0, 150.0]]).tolist() == [True, True, True]


def test_a_box_with_buildings_and_no_road_gets_a_free_driving_target(tmp_path: Path) -> None:
    """Only w206 (235-305 m east, 10-90 m north) lies in this box; no road reaches into it."""
    source = write_xml(tmp_path / "town.osm")
    box = ",".join(repr(v) for v in box_degrees((220.0, 10.0, 320.0, 95.0)))
    out = tmp_path / "shed.toml"
    assert main(["scenario", "from-osm", str(source), f"--bbox={box}", "--out", str(out)]) == 0
    assert not out.with_name("shed_roads.geojson").exists()
    scenario = load_scenario(out)
    assert scenario.city.roads_geojson is None and scenario.target.motion == "white_noise_acceleration"
    world = build_world(scenario, tmp_path)
    assert len(world.buildings) == 1 and world.roads is None
    assert world.inside(np.array([scenario.target.start_enu_m])).all()
