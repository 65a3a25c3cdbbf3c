"""The roads on Foxglove's map: ``/map/world`` of an MCAP file, read back, held against the world's road graph.

Both ways an MCAP file is written: live (``--foxglove-mcap``, the live map's
Foxglove output) and from a recording (``gcs replay FILE --foxglove-mcap``). Every
road is a LineString feature (``kind`` ``road``) in WGS84 ``[lon, lat]``; taken back
to ENU through the scenario's origin (at the origin's height: GeoJSON has none, and the
ground 3 km away is 0.7 m higher than the origin on the ellipsoid, which moves it 0.3 mm),
every vertex is within 0.01 m of the graph's node (centimetres on the map, 1e-8 degrees,
about a millimetre, in the file), and the LineStrings' consecutive vertex pairs are
the graph's segments, each once, a one-way road's in its driving sense. The extent's
outline is the world's ``bounds_m``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from gcs.adapters.foxglove_out import FoxgloveOptions
from gcs.adapters.live_map.outputs import LiveMap
from gcs.config.world import build_world
from gcs.core.geometry import LocalFrame
from gcs.recordings.replay_view import to_foxglove
from gcs.scenarios import load_scenario
from tests.integration.test_foxglove_out import _geojson
from tests.recordings import still_recording
from tests.road_segments import assert_lines_are_the_graph

TOLERANCE_M = 0.01


def _live(scenario, world, out: Path, folder: Path) -> None:
    live = LiveMap.open(None, scenario, world, foxglove=FoxgloveOptions(mcap=out))
    try:
        assert live.publish(0.0, force=True)
    finally:
        live.close()


def _replayed(scenario, world, out: Path, folder: Path) -> None:
    to_foxglove(still_recording(folder / "still.mcap", scenario, steps=3), scenario, world, out)


@pytest.mark.parametrize("name, write", [("helsinki_centre", _live), ("helsinki_centre", _replayed),
                                         ("wang2012_urban", _replayed)])
def test_the_map_topic_carries_every_road_as_a_linestring_where_the_graph_has_it(name, write, tmp_path: Path) -> None:
    scenario = load_scenario(name)
    world = build_world(scenario)
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    out = tmp_path / "map.mcap"
    write(scenario, world, out, tmp_path)
    with open(out, "rb") as stream:
        messages = [(schema.name, m) for schema, channel, m in make_reader(stream).iter_messages()
                    if channel.topic == "/map/world"]
    assert messages and {schema for schema, _ in messages} == {"foxglove.GeoJSON"}
    features = _geojson(messages[-1][1].data)["features"]
    roads = [f for f in features if f["properties"]["kind"] == "road"]
    assert roads and {f["geometry"]["type"] for f in roads} == {"LineString"}

    def enu(lonlat: list[list[float]]) -> np.ndarray:
        lon, lat = np.array(lonlat).T
        return frame.to_enu(lat, lon, np.full_like(lat, scenario.origin.height_m))[:, :2]

    one_way = [f["properties"]["one_way"] for f in roads]
    segments = assert_lines_are_the_graph([enu(f["geometry"]["coordinates"]) for f in roads], one_way, world.roads,
                                          TOLERANCE_M)
    one_way_edges = int((world.roads.reverse < 0).sum())
    assert segments == one_way_edges + (len(world.roads) - one_way_edges) // 2
    assert any(one_way) == (one_way_edges > 0)

    (extent,) = [f for f in features if f["properties"]["kind"] == "extent"]
    (ring,) = extent["geometry"]["coordinates"]
    corners = enu(ring)
    assert ring[0] == ring[-1] and len(ring) == 5
    west, south, east, north = world.bounds_m
    assert corners.min(axis=0) == pytest.approx([west, south], abs=0.06)  # the map's decimetres
    assert corners.max(axis=0) == pytest.approx([east, north], abs=0.06)
    # the buildings are there as before, beside the roads
    assert sum(f["properties"]["kind"] == "building" for f in features) == len(world.buildings)
