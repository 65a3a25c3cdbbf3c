"""A car turns behind a building, in the closed loop: the road tracker follows it, the constant-velocity DUIF does not.

A cross junction built by hand: two 1.2 km streets, 20 m wide, meet at the origin; four 60 m blocks fill the
quadrants, so that two UAVs at 150-160 m see a car only from above its street's corridor (about 25 m either
side). The car drives north up the south street at 10 m/s, turns east at the junction at t = 40 s and drives on
east, hidden by the blocks from UAVs above the north-south street. The UAVs fly the sight planner.

Figure compared with: the same closed loop, same seeds, with the constant-velocity DUIF (``[estimator] kind =
"duif"``), whose prediction carries on north through the corner the car turned at. The road tracker's
prediction branches at the junction, the UAVs' empty looks up the north street move its weight to the
east and west arms, and the planner looks down them.
"""

from __future__ import annotations

import json
from pathlib import Path

import msgspec
import numpy as np
import pytest

from benchmarks.urban import run_closed_loop
from gcs.config.world import build_world
from gcs.scenarios import load_scenario

pytestmark = pytest.mark.slow

HALF_M, STREET_HALF_M, BLOCK_HEIGHT_M = 600.0, 10.0, 60.0
TURN_STEP = 40
SEEDS = range(6)
SCENARIO = f"""
name = "corner"
[origin]
lat_deg = 60.0
lon_deg = 25.0
[time]
duration_s = 80.0
[city]
kind = "geojson"
geojson = "blocks.geojson"
roads_geojson = "roads.geojson"
[planner.sight]
reach_m = 250.0
[[vehicles]]
id = "uav1"
sysid = 1
altitude_m = 150.0
speed_mps = 20.0
max_turn_rate_rad_s = 0.2
start_enu_m = [0.0, -500.0]
start_heading_rad = 1.571
[[vehicles]]
id = "uav2"
sysid = 2
altitude_m = 160.0
speed_mps = 20.0
max_turn_rate_rad_s = 0.2
start_enu_m = [0.0, -550.0]
start_heading_rad = 1.571
[target]
motion = "scripted"
start_enu_m = [0.0, -400.0]
path = [[0.0, 0.0, -400.0], [{TURN_STEP}.0, 0.0, 0.0], [80.0, 400.0, 0.0]]
"""


def _collection(features: list[dict]) -> str:
    return json.dumps({"type": "FeatureCollection", "gcs_frame": "enu", "features": features})


def _block(x0: float, y0: float, x1: float, y1: float) -> dict:
    ring = [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]
    return {"type": "Feature", "properties": {"height": BLOCK_HEIGHT_M}, "geometry": {"type": "Polygon",
                                                                                      "coordinates": [ring]}}


def _street(points: list[list[float]]) -> dict:
    return {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": points}}


@pytest.fixture(scope="module")
def corner(tmp_path_factory) -> tuple[object, object]:
    """The scenario and its world (files written beside the scenario)."""
    folder: Path = tmp_path_factory.mktemp("corner")
    near, far = STREET_HALF_M, HALF_M
    side = {1: (near, far), -1: (-far, -near)}  # a block's extent on one axis, east/north (1) or west/south (-1)
    blocks = [_block(side[sx][0], side[sy][0], side[sx][1], side[sy][1]) for sx in (1, -1) for sy in (1, -1)]
    (folder / "blocks.geojson").write_text(_collection(blocks))
    # the streets meet at a shared vertex: the junction
    (folder / "roads.geojson").write_text(_collection([_street([[0.0, -far], [0.0, 0.0], [0.0, far]]),
                                                       _street([[-far, 0.0], [0.0, 0.0], [far, 0.0]])]))
    (folder / "corner.toml").write_text(SCENARIO)
    scenario = load_scenario(folder / "corner.toml")
    return scenario, build_world(scenario, folder)


def _errors_after_the_turn(scenario, world, kind: str) -> np.ndarray:
    """Per seed (rows), the track's error at every step from the turn on."""
    chosen = msgspec.structs.replace(scenario, estimator=msgspec.structs.replace(scenario.estimator, kind=kind))
    rows = []
    for seed in SEEDS:
        record = run_closed_loop(chosen, world, "sight", seed, clock=None)
        assert np.all(np.isfinite(record.errors_m[TURN_STEP:])), (kind, seed)
        rows.append(record.errors_m[TURN_STEP:])
    return np.array(rows)


def test_the_road_track_follows_the_car_round_the_hidden_corner(corner) -> None:
    scenario, world = corner
    assert scenario.estimator.kind == "auto" and world.roads is not None  # the road tracker by default
    road, duif = (_errors_after_the_turn(scenario, world, kind) for kind in ("road", "duif"))
    rmse_road, rmse_duif = np.sqrt((road**2).mean(axis=1)), np.sqrt((duif**2).mean(axis=1))
    # on every seed the road track's error after the turn is below the DUIF's; pooled, under half of it
    # (recorded: 62 m against 168 m)
    assert np.all(rmse_road < rmse_duif), (rmse_road, rmse_duif)
    assert np.sqrt((road**2).mean()) < 0.5 * np.sqrt((duif**2).mean())
    # and the track is on the car again by the end, on every seed: within 15 m over the last 5 steps (a range
    # detection is good to 10 m; recorded: at most 7.4 m)
    assert np.all(road[:, -5:].max(axis=1) < 15.0), road[:, -5:]
