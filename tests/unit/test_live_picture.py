"""The live map's picture: what the page is given, built from wire messages (no network)."""

from __future__ import annotations

import json
import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from gcs.core.geometry import LocalFrame
from gcs.core.world import Buildings, RestrictedAirspace, World
from gcs.adapters.live_map.picture import TRAIL_STEP_S, Picture
from gcs.adapters.live_map.picture_geometry import SIGMAS, ellipse, encode_json, world_geometry
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.messages import (DaemonStatus, GpsFix, Measurement, NavReport, PlanCommand, PredictedPoint, SensorReport,
                                TargetTruth, TrackEstimate, VehicleStatus)

SCENARIO = load_scenario("wang2012_urban")
NS = 1_000_000_000
T0 = 1_000 * NS


def _report(vehicle: str, stamp: int, xyz: tuple[float, float, float], detected: bool = False) -> SensorReport:
    values = {"azimuth_rad": 0.3, "azimuth_std_rad": 0.05} if detected else {}
    return SensorReport(vehicle_id=vehicle, seq=1, stamp_ns=stamp, vehicle_position_enu_m=xyz,
                        detections=(Measurement(**values),) if detected else ())


def _track(stamp: int, xy: tuple[float, float], cov_xy=(100.0, 0.0, 0.0, 25.0), seq: int = 1,
           target_id: str = "target") -> TrackEstimate:
    cov = np.zeros((4, 4))
    cov[:2, :2] = np.reshape(cov_xy, (2, 2))
    cov[2, 2] = cov[3, 3] = 4.0
    prediction = tuple(PredictedPoint(stamp_ns=stamp + k * NS, position_enu_m=(xy[0] + k, xy[1]),
                                      position_cov_m2=(4.0 * k, 0.0, 0.0, 4.0 * k)) for k in (1, 2, 3))
    return TrackEstimate(target_id=target_id, seq=seq, stamp_ns=stamp, model="cv2d", state=(*xy, 1.0, 0.0),
                         covariance=tuple(cov.ravel()), contributing_vehicles=("uav1",), prediction=prediction)


def _truth(stamp: int, xy: tuple[float, float], target_id: str = "target") -> TargetTruth:
    return TargetTruth(target_id=target_id, seq=1, stamp_ns=stamp, position_enu_m=xy, velocity_enu_mps=(0.0, 0.0))


def _snapshot(picture: Picture, *args, **kwargs) -> tuple[dict, dict]:
    """The documents as the page gets them (trails are embedded JSON until encoded)."""
    return tuple(json.loads(encode_json(document)) for document in picture.snapshot(*args, **kwargs))


def _vehicle(tracks: dict, vehicle_id: str) -> dict:
    return next(v for v in tracks["vehicles"] if v["id"] == vehicle_id)


def test_ellipse_axes_are_the_eigen_decomposition_at_two_sigma() -> None:
    cov = np.array([[300.0, 120.0], [120.0, 80.0]])
    values, vectors = np.linalg.eigh(cov)  # ascending
    e = ellipse(cov)
    assert math.isclose(e["rx"], SIGMAS * math.sqrt(values[1]), abs_tol=0.05)
    assert math.isclose(e["ry"], SIGMAS * math.sqrt(values[0]), abs_tol=0.05)
    major = vectors[:, 1]
    assert abs(math.sin(e["angle_rad"] - math.atan2(major[1], major[0]))) < 1e-3  # same axis, either sense


@given(st.floats(1.0, 1e6), st.floats(1.0, 1e6), st.floats(-0.99, 0.99), st.floats(0.0, 2 * math.pi))
def test_points_of_the_ellipse_are_at_mahalanobis_distance_two(var_x, var_y, rho, along) -> None:
    b = rho * math.sqrt(var_x * var_y)
    cov = np.array([[var_x, b], [b, var_y]])
    e = ellipse(cov.ravel())
    rounding = 0.05 / max(e["ry"], 0.05)  # the axes are rounded to the decimetre
    c, s = math.cos(e["angle_rad"]), math.sin(e["angle_rad"])
    point = np.array([e["rx"] * math.cos(along) * c - e["ry"] * math.sin(along) * s,
                      e["rx"] * math.cos(along) * s + e["ry"] * math.sin(along) * c])
    assert math.isclose(math.sqrt(point @ np.linalg.solve(cov, point)), SIGMAS, rel_tol=rounding + 1e-6)


def test_world_geometry_has_every_building_and_no_fly_zone() -> None:
    world = World(Buildings.from_boxes([[0, 0, 10, 20], [50, 50, 70, 60]], [30.0, 40.0]),
                  RestrictedAirspace.from_zones([([(100, 100), (200, 100), (200, 200)], 0.0, 500.0)], ["tower"]),
                  None, (1000.0, 800.0))
    geometry = world_geometry(SCENARIO, world)
    assert geometry["size_m"] == [1000.0, 800.0]
    assert [b["height_m"] for b in geometry["buildings"]] == [30.0, 40.0]
    assert sorted(map(tuple, geometry["buildings"][1]["footprint"])) == [(50, 50), (50, 60), (70, 50), (70, 60)]
    assert geometry["no_fly"] == [{"name": "tower", "polygon": [[100, 100], [200, 100], [200, 200]],
                                   "floor_m": 0.0, "ceiling_m": 500.0}]
    assert [v["id"] for v in geometry["vehicles"]] == ["uav1", "uav2", "uav3"]


def test_vehicles_are_placed_from_gps_and_reports_whichever_is_newer() -> None:
    picture = Picture(SCENARIO, World.empty())
    frame = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
    lat, lon, height = frame.to_geodetic([1234.5, -678.9, 200.0])
    gps = GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=float(height), fix_type=3, h_acc_m=2.0, v_acc_m=3.0)
    picture.observe(_report("uav1", T0, (10.0, 20.0, 200.0), detected=True))
    picture.observe(NavReport(vehicle_id="uav1", seq=1, stamp_ns=T0 + NS // 5, gps=gps, heading_rad=0.7))
    tracks, _ = _snapshot(picture)
    uav1 = _vehicle(tracks, "uav1")
    assert (uav1["x"], uav1["y"]) == (1234.5, -678.9) and uav1["heading_rad"] == 0.7 and uav1["detected"] is True
    picture.observe(_report("uav1", T0 - NS, (0.0, 0.0, 200.0)))  # older: does not move it back
    tracks, _ = _snapshot(picture)
    assert (_vehicle(tracks, "uav1")["x"], _vehicle(tracks, "uav1")["reports"]) == (1234.5, 2)
    assert _vehicle(tracks, "uav2")["x"] is None  # never heard of: listed, not placed


def test_trails_take_one_point_per_trail_step_of_stamp_time() -> None:
    picture = Picture(SCENARIO, World.empty())
    step = round(TRAIL_STEP_S * NS)
    for k in range(20):  # five reports per trail step
        picture.observe(_report("uav2", T0 + k * step // 5, (float(k), 0.0, 200.0)))
    trail = _vehicle(_snapshot(picture)[0], "uav2")["trail"]
    assert trail == [[float(k), 0.0, k // 5] for k in range(0, 20, 5)]  # [x, y, whole s from the first stamp]
    picture.observe(_report("uav1", T0 - NS, (0.0, 0.0, 200.0)))  # older than the first: the trails' epoch stays
    tracks, _ = _snapshot(picture)
    assert tracks["trail_epoch_ns"] == T0 and _vehicle(tracks, "uav2")["trail"] == trail
    assert _vehicle(tracks, "uav1")["trail"] == [[0.0, 0.0, -1.0]]


def test_track_prediction_plan_and_truth_with_the_rmse_of_matched_stamps() -> None:
    picture = Picture(SCENARIO, World.empty())
    plan = PlanCommand(vehicle_id="uav3", seq=1, stamp_ns=T0, heading_rad=0.1, turn_rate_rad_s=0.0, airspeed_mps=25.0,
                       altitude_m=200.0, planned_path_enu_m=((1.0, 2.0), (3.0, 4.0)), planner="ga_k5")
    picture.observe(plan)
    picture.observe(_truth(T0, (100.0, 100.0)))
    picture.observe(_track(T0, (103.0, 104.0)))  # error 5 m, truth already there
    picture.observe(_track(T0 + NS, (110.0, 100.0), seq=2))  # error 12 m, truth comes after it
    picture.observe(_truth(T0 + NS + NS // 20, (98.0, 100.0)))  # within a tenth of the 1 s step
    tracks, status = _snapshot(picture)
    assert _vehicle(tracks, "uav3")["plan"] == [[1.0, 2.0], [3.0, 4.0]]
    (track,) = tracks["tracks"]
    assert (track["x"], track["y"], track["seq"]) == (110.0, 100.0, 2)
    assert (track["ellipse"]["rx"], track["ellipse"]["ry"]) == (20.0, 10.0)  # 2 sigma of 10 m and 5 m
    assert [p["x"] for p in track["prediction"]] == [111.0, 112.0, 113.0]
    assert track["trail"] == [[103.0, 104.0, 0.0], [110.0, 100.0, 1.0]]  # the truth came first, at T0
    assert tracks["truth"][0]["x"] == 98.0
    assert math.isclose(status["rmse_m"], math.sqrt((5.0**2 + 12.0**2) / 2), abs_tol=0.01)
    assert status["errors"]["target"]["scored"] == 2


def test_no_rmse_without_truth_and_a_track_far_from_any_truth_stamp_is_not_scored() -> None:
    picture = Picture(SCENARIO, World.empty())
    picture.observe(_track(T0, (0.0, 0.0)))
    picture.observe(_truth(T0 + NS // 2, (0.0, 0.0)))  # half a step away: not the same instant
    _, status = _snapshot(picture)
    assert status["rmse_m"] is None and status["errors"] == {}


def test_links_come_from_the_daemon_status_when_given_else_from_tokens_and_data_age() -> None:
    picture = Picture(SCENARIO, World.empty(), mode="replay")
    picture.observe(_report("uav1", T0, (0.0, 0.0, 200.0)))
    picture.observe(_report("uav2", T0 - 10 * NS, (0.0, 0.0, 200.0)))
    picture.on_liveliness("uav3", False)
    links = {v["id"]: v["link"] for v in _snapshot(picture)[1]["vehicles"]}
    assert links == {"uav1": "ok", "uav2": "lost", "uav3": "lost"}
    status = DaemonStatus(stamp_ns=T0, uptime_s=12.0, scenario="x", counters={"decisions": 7},
                          vehicles=(VehicleStatus(vehicle_id="uav1", link="lost", reports=3, sysid=1,
                                                  autopilot="PX4"),))
    _, summary = _snapshot(picture, status, extra={"replay": {"playing": True}})
    assert summary["vehicles"][0] | {"reports": 0} == {"id": "uav1", "link": "lost", "reports": 0, "detected": False,
                                                       "sysid": 1, "autopilot": "PX4"}
    assert summary["counters"]["decisions"] == 7 and summary["uptime_s"] == 12.0
    assert summary["replay"] == {"playing": True}


def test_wire_payloads_are_decoded_and_bad_ones_counted_not_raised() -> None:
    picture = Picture(SCENARIO, World.empty())
    picture.observe_wire(*encode(_report("uav1", T0, (5.0, 6.0, 200.0))))
    picture.observe_wire(b'{"vehicle_id": 3}', "application/json;gcs.SensorReport/1")
    picture.observe_wire(b"not json", "text/plain")
    tracks, status = _snapshot(picture)
    assert _vehicle(tracks, "uav1")["x"] == 5.0
    assert status["counters"]["picture.rejected"] == 2


def test_gps_fixes_place_the_vehicle_and_its_trail_in_enu() -> None:
    picture = Picture(SCENARIO, World.empty())
    frame = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
    for k in range(4):  # every half second, 10 m further east each time
        lat, lon, height = frame.to_geodetic([100.0 + 10.0 * k, 50.0, 200.0])
        gps = GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=float(height), fix_type=3, h_acc_m=2.0, v_acc_m=3.0)
        picture.observe(NavReport(vehicle_id="uav3", seq=k + 1, stamp_ns=T0 + k * NS // 2, gps=gps))
    uav3 = _vehicle(_snapshot(picture)[0], "uav3")
    assert (uav3["x"], uav3["y"], uav3["stamp_ns"]) == (130.0, 50.0, T0 + 3 * NS // 2)  # the newest fix
    assert uav3["trail"] == [[100.0, 50.0, 0.0], [120.0, 50.0, 1.0]]  # one point a second of stamp time


def test_a_track_no_longer_published_leaves_the_map_and_one_still_published_stays() -> None:
    picture = Picture(SCENARIO, World.empty())
    for k in range(3):
        picture.observe(_track(T0 + k * NS, (float(k), 0.0), seq=k + 1, target_id="t1"))
        picture.observe(_track(T0 + k * NS, (0.0, float(k)), seq=k + 1, target_id="t2"))
    assert [t["target_id"] for t in _snapshot(picture)[0]["tracks"]] == ["t1", "t2"]
    listed = []
    for k in range(3, 6):  # t2 stops at T0 + 2 s; t1 goes on to T0 + 5 s
        picture.observe(_track(T0 + k * NS, (float(k), 0.0), seq=k + 1, target_id="t1"))
        listed.append([t["target_id"] for t in _snapshot(picture)[0]["tracks"]])
    assert listed == [["t1", "t2"], ["t1", "t2"], ["t1"]]  # 1 and 2 s behind: kept; 3 s: gone
    tracks, status = _snapshot(picture)
    (t1,) = tracks["tracks"]
    assert (t1["x"], t1["stamp_ns"], len(t1["trail"])) == (5.0, T0 + 5 * NS, 6)
    assert status["last_track_stamp_ns"] == T0 + 5 * NS
    assert "t2" not in picture.targets  # known by its track alone: forgotten with its trail


def test_the_staleness_bound_is_inclusive_and_a_track_back_under_its_id_starts_a_new_trail() -> None:
    picture = Picture(SCENARIO, World.empty())
    picture.observe(_truth(T0, (0.0, 0.0), target_id="t2"))
    picture.observe(_track(T0, (0.0, 0.0), target_id="t2"))
    picture.observe(_track(T0 + 5 * NS // 2, (9.0, 9.0), target_id="t1"))  # exactly 2.5 steps of 1 s newer
    assert [t["target_id"] for t in _snapshot(picture)[0]["tracks"]] == ["t2", "t1"]
    picture.observe(_track(T0 + 5 * NS // 2 + 1, (9.0, 9.0), target_id="t1"))  # one nanosecond more
    tracks, _ = _snapshot(picture)
    assert [t["target_id"] for t in tracks["tracks"]] == ["t1"]
    assert [t["target_id"] for t in tracks["truth"]] == ["t2"]  # the truth is drawn as before
    picture.observe(_track(T0 + 3 * NS, (50.0, 60.0), target_id="t2"))  # a new track under the old id
    t2 = next(t for t in _snapshot(picture)[0]["tracks"] if t["target_id"] == "t2")
    assert t2["trail"] == [[50.0, 60.0, 3.0]]


def test_when_every_track_stops_the_reports_stamps_take_the_last_tracks_off_the_map() -> None:
    """No track is newer than the last ones once the tracker has deleted them all: the reports go on."""
    assert SCENARIO.time.step_s == 1.0
    picture = Picture(SCENARIO, World.empty())
    picture.observe(_track(T0, (0.0, 0.0), target_id="t1"))
    picture.observe(_track(T0, (5.0, 0.0), target_id="t2"))
    picture.observe(_report("uav1", T0 + 5 * NS // 2, (0.0, 0.0, 200.0)))  # 2.5 steps on: the bound, inclusive
    assert [t["target_id"] for t in _snapshot(picture)[0]["tracks"]] == ["t1", "t2"]
    picture.observe(_report("uav1", T0 + 3 * NS, (0.0, 0.0, 200.0)))
    assert _snapshot(picture)[0]["tracks"] == [] and not picture.targets
