"""The payload bridge's pure part (sim_vehicles.payload): telemetry -> pose, reports, liveliness.

Figures to compare with are computed here by other means: the pose from the WGS84
radii of curvature by hand, the sensor report from the scene's own computation for
the same pose and from the geometry of the target's truth, the liveliness from the
telemetry's arrival times.
"""

from __future__ import annotations

import logging

import math

import numpy as np
import pytest

from gcs.adapters.mavlink_wire import mavlink
from gcs.config.world import build_world
from gcs.core.geometry import WGS84_A, WGS84_F
from gcs.core.world.los import line_of_sight
from gcs.scenarios import load_scenario
from sim_vehicles.payload import Liveliness, PayloadBridge
from sim_vehicles.payload_telemetry import USER_RANGE_ERROR_M, BadTelemetry, VehicleTelemetry, gps_status
from sim_vehicles.scene import Scene
from sim_vehicles.truth.fixed_wing import AirframeState

SCENARIO = load_scenario("wang2012_urban")
WORLD = build_world(SCENARIO)
ORIGIN = SCENARIO.origin
EPOCH_NS = 1_700_000_000_000_000_000
SEED = 7


def global_position(east_m: float, north_m: float, up_m: float, v_enu=(0.0, 0.0, 0.0), hdg_cdeg: int = 65535,
                    lat_e7: int | None = None, lon_e7: int | None = None):
    """GLOBAL_POSITION_INT for a point east/north/up of home, from the WGS84 radii of curvature by hand: the
    meridian's M = a (1 - e^2) / (1 - e^2 sin^2 phi)^1.5 at home for the latitude, the prime vertical's
    N = a / sqrt(1 - e^2 sin^2 phi) at the point's latitude for the longitude (true to a few centimetres within
    1.5 km of home: the terms left out are of order distance^2 / Earth radius x tan(latitude))."""
    e2 = WGS84_F * (2.0 - WGS84_F)
    h = ORIGIN.height_m + up_m
    phi = math.radians(ORIGIN.lat_deg)
    lat = ORIGIN.lat_deg + math.degrees(north_m / (WGS84_A * (1.0 - e2) / (1.0 - e2 * math.sin(phi) ** 2) ** 1.5
                                                   + h))
    phi = math.radians(lat)
    prime = WGS84_A / math.sqrt(1.0 - e2 * math.sin(phi) ** 2)
    lon = ORIGIN.lon_deg + math.degrees(math.asin(east_m / ((prime + h) * math.cos(phi))))
    return mavlink.MAVLink_global_position_int_message(
        0, round(lat * 1e7) if lat_e7 is None else lat_e7, round(lon * 1e7) if lon_e7 is None else lon_e7,
        round(h * 1000), round(up_m * 1000), round(v_enu[1] * 100), round(v_enu[0] * 100), round(-v_enu[2] * 100),
        hdg_cdeg)


def attitude(yaw_ned: float, yawspeed: float = 0.0, roll: float = 0.0):
    return mavlink.MAVLink_attitude_message(0, roll, 0.0, yaw_ned, 0.0, 0.0, yawspeed)


def gps_raw(fix_type: int = 3, h_acc_mm: int = 1500, v_acc_mm: int = 2500, eph: int = 120, satellites: int = 12):
    return mavlink.MAVLink_gps_raw_int_message(0, fix_type, 0, 0, 0, eph, 200, 0, 0, satellites, 0, h_acc_mm,
                                               v_acc_mm, 0, 0)


def bridge(vehicles=("uav1",), stale_after_s: float = 3.0) -> PayloadBridge:
    b = PayloadBridge(SCENARIO, WORLD, list(vehicles), SEED, stale_after_s)
    b.start(EPOCH_NS)
    return b


def feed(b: PayloadBridge, now_s: float, *messages, vehicle: str = "uav1") -> None:
    for message in messages:
        b.ingest(vehicle, message, now_s)


def published(actions, kind: str, ident: str = "uav1") -> list:
    return [a.message for a in actions if not isinstance(a, Liveliness) and a.kind == kind and a.ident == ident]


def test_global_position_int_gives_the_enu_pose_of_a_hand_computed_point() -> None:
    telemetry = VehicleTelemetry(Scene(SCENARIO, WORLD, 0, 0, only=("uav1",)).frame)
    telemetry.ingest(global_position(500.0, 1000.0, 200.0, v_enu=(20.0, 10.0, 1.0), hdg_cdeg=9000), 0.0)
    pose = telemetry.pose(0.0)
    np.testing.assert_allclose(pose.position_enu_m, [500.0, 1000.0, 200.0], atol=0.1)  # 1e-7 deg is 1.1 cm
    np.testing.assert_allclose(pose.velocity_enu_mps, [20.0, 10.0, 1.0])
    assert pose.heading_rad == pytest.approx(0.0, abs=1e-12)  # hdg 90 deg NED: east, ENU 0
    telemetry.ingest(attitude(math.radians(30.0), yawspeed=0.1, roll=0.2), 0.0)  # 30 deg east of north
    pose = telemetry.pose(0.5)
    assert pose.heading_rad == pytest.approx(math.radians(60.0) - 0.1 * 0.5)  # ENU 60 deg, turning clockwise
    assert (pose.turn_rate_rad_s, pose.roll_rad) == (pytest.approx(-0.1), pytest.approx(0.2))
    np.testing.assert_allclose(pose.position_enu_m, [510.0, 1005.0, 200.5], atol=0.05)  # carried 0.5 s on


def test_gps_raw_int_gives_fix_accuracy_and_satellites() -> None:
    status = gps_status(gps_raw(fix_type=3, h_acc_mm=1500, v_acc_mm=2500, satellites=255))
    assert (status.fix_type, status.h_acc_m, status.v_acc_m, status.satellites) == (3, 1.5, 2.5, None)
    from_dop = gps_status(gps_raw(h_acc_mm=0, eph=120, satellites=9))  # no h_acc: HDOP 1.2 x the range error
    assert from_dop.h_acc_m == pytest.approx(1.2 * USER_RANGE_ERROR_M) and from_dop.satellites == 9
    assert math.isnan(gps_status(gps_raw(h_acc_mm=0, eph=65535)).h_acc_m)
    with pytest.raises(BadTelemetry, match="fix type 9"):
        gps_status(gps_raw(fix_type=9))


def test_bad_telemetry_is_counted_and_changes_nothing() -> None:
    b = bridge()
    feed(b, 0.0, global_position(100.0, 200.0, 150.0), gps_raw())
    bad = [global_position(0, 0, 150.0, lat_e7=95 * 10**7), global_position(0, 0, 150.0, lat_e7=2 * 10**6, lon_e7=0),
           global_position(0, 0, 150.0, hdg_cdeg=40000), attitude(float("nan")), gps_raw(fix_type=12)]
    assert [b.ingest("uav1", m, 0.1) for m in bad] == [False] * 5
    counts = b.counts["uav1"]
    assert (counts["messages"], counts["bad_telemetry"], counts["positions_without_fix"]) == (7, 5, 0)
    navs = published(b.advance(0.2), "nav")
    assert len(navs) == 2  # t = 0 and 0.2 (nav_rate_hz 5)
    np.testing.assert_allclose(b.vehicles["uav1"].telemetry.pose(0.2).position_enu_m, [100.0, 200.0, 150.0],
                               atol=0.05)
    assert navs[-1].gps.fix_type == 3 and navs[-1].gps.h_acc_m == 1.5


def test_reports_come_at_the_scenario_rates_on_the_bridge_clock() -> None:
    b = bridge()
    feed(b, 0.0, global_position(1500.0, 1500.0, 200.0), attitude(0.0), gps_raw())
    actions = b.advance(0.0)
    assert actions[0] == Liveliness("uav1", True)
    for k in range(1, 21):  # telemetry at 10 Hz for 2 s
        feed(b, k / 10, global_position(1500.0, 1500.0, 200.0), attitude(0.0))
        actions += b.advance(k / 10)
    navs, reports, truths = published(actions, "nav"), published(actions, "report"), published(actions, "truth",
                                                                                              "target")
    assert [n.stamp_ns - EPOCH_NS for n in navs] == [k * 200_000_000 for k in range(11)]
    assert [r.stamp_ns - EPOCH_NS for r in reports] == [0, 1_000_000_000, 2_000_000_000]
    assert [t.stamp_ns for t in truths] == [r.stamp_ns for r in reports]
    assert [n.seq for n in navs] == list(range(1, 12))


def test_nav_report_carries_the_fix_and_the_ins_increments() -> None:
    b = bridge()
    speed, yaw_rate = 25.0, 0.1  # flying north, turning clockwise (NED yaw rate > 0) at 0.1 rad/s
    feed(b, 0.0, global_position(1000.0, 1000.0, 200.0, v_enu=(0.0, speed, 0.0)), attitude(0.0, yaw_rate),
         gps_raw(h_acc_mm=1800, v_acc_mm=2600, satellites=11))
    navs = published(b.advance(0.4), "nav")
    first, third = navs[0], navs[2]
    assert first.ins is None and first.velocity_enu_mps == pytest.approx((0.0, speed, 0.0))
    assert (third.gps.fix_type, third.gps.h_acc_m, third.gps.v_acc_m, third.gps.satellites) == (3, 1.8, 2.6, 11)
    assert third.gps.alt_m == pytest.approx(ORIGIN.height_m + 200.0)
    frame = b.scene.frame
    east, north, _ = frame.to_enu(third.gps.lat_deg, third.gps.lon_deg, third.gps.alt_m)
    assert (east, north) == (pytest.approx(1000.0, abs=0.1), pytest.approx(1000.0 + speed * 0.4, abs=0.1))
    assert third.ins.dt_s == pytest.approx(0.2) and third.ins.distance_m == pytest.approx(speed * 0.2)
    assert third.ins.heading_change_rad == pytest.approx(-yaw_rate * 0.2)
    assert third.heading_rad == pytest.approx(math.pi / 2 - yaw_rate * 0.4)
    assert third.turn_rate_rad_s == pytest.approx(-yaw_rate)


def test_no_fix_gives_no_gps_and_no_position_std() -> None:
    b = bridge()
    feed(b, 0.0, global_position(1000.0, 1000.0, 200.0, v_enu=(25.0, 0.0, 0.0)), gps_raw(fix_type=1))
    actions = b.advance(0.2)
    navs, reports = published(actions, "nav"), published(actions, "report")
    assert all(n.gps is None for n in navs)
    assert navs[0].velocity_enu_mps is not None and navs[1].ins.distance_m == pytest.approx(5.0)
    assert reports[0].vehicle_position_std_m is None


def test_sensor_report_is_the_scenes_own_for_the_same_pose_and_the_target_geometry() -> None:
    b = bridge(("uav2",))
    east, north, up = 1520.0, 1480.0, 210.0  # about above the target's start, (1500, 1500)
    reports, truths = [], []
    for k in range(0, 51):  # telemetry at 10 Hz for 5 s, standing still (no carrying on to blur the pose)
        feed(b, k / 10, global_position(east, north, up), attitude(0.0), gps_raw(h_acc_mm=2000), vehicle="uav2")
        actions = b.advance(k / 10)
        reports += published(actions, "report", "uav2")
        truths += published(actions, "truth", "target")
    assert len(reports) == 6
    # The scene's own computation: the same scenario, seed and vehicle, its target moved by the same steps.
    scene = Scene(SCENARIO, WORLD, SEED, EPOCH_NS, only=("uav2",))
    pose = b.vehicles["uav2"].telemetry.pose(5.0).position_enu_m
    vehicle, dt = scene.vehicles["uav2"], SCENARIO.simulation.physics_step_s
    expected = []
    for k in range(6):
        while scene.elapsed_s < k - 1e-9:
            scene.skip_target(dt)
        vehicle.state = AirframeState(pose.copy(), math.pi / 2, 0.0, 0.0)
        vehicle.nav_position_enu_m, vehicle.nav_std_m = pose.copy(), 2.0
        expected.append(scene.sensor_report("uav2"))
    assert reports == expected
    # The geometry of the published truth: detected where the line of sight is clear, range and azimuth
    # within 5 sigma of the exact ones.
    for report, truth in zip(reports, truths, strict=True):
        target = np.array([*truth.position_enu_m, 0.0])
        clear = bool(line_of_sight(WORLD.buildings, target[None], pose[None])[0])
        assert report.detected == clear
        if report.detected:
            offset = target - pose
            (detection,) = report.detections
            assert abs(detection.range_m - np.linalg.norm(offset)) < 5 * 10.0
            assert abs(math.remainder(detection.azimuth_rad - math.atan2(offset[1], offset[0]), 2 * math.pi)) < 0.25
            assert report.vehicle_position_std_m == 2.0
    assert any(r.detected for r in reports)


def test_liveliness_is_withdrawn_on_stale_telemetry_and_declared_when_it_returns() -> None:
    b = bridge(("uav1", "uav3"), stale_after_s=1.0)
    changes, reports = [], []
    for k in range(0, 41):  # uav1: telemetry for the first 1.5 s, then none until 3.0 s; uav3: never any
        t = k / 10
        if t <= 1.5 or t >= 3.0:
            feed(b, t, global_position(1000.0, 1000.0, 200.0), gps_raw())
        actions = b.advance(t)
        changes += [(round(t, 2), a) for a in actions if isinstance(a, Liveliness)]
        reports += published(actions, "nav")
    assert changes == [(0.0, Liveliness("uav1", True)), (2.6, Liveliness("uav1", False)),
                       (3.0, Liveliness("uav1", True))]
    stale = [r for r in reports if 2.5e9 < r.stamp_ns - EPOCH_NS < 3.0e9]
    assert stale == []  # nothing published while withdrawn
    assert b.counts["uav1"]["withdrawn"] == 1 and b.counts["uav3"]["nav_reports"] == 0


def test_positions_before_a_gps_fix_are_dropped_counted_and_logged_once(caplog) -> None:
    b = bridge()
    before_fix = [global_position(0, 0, 0.0, lat_e7=lat, lon_e7=lon) for lat, lon in ((0, 0), (1930, 2330), (-2904, -205))]
    with caplog.at_level(logging.INFO, logger="sim_vehicles.payload"):
        assert [b.ingest("uav1", m, 0.1 * k) for k, m in enumerate(before_fix)] == [False] * 3
    counts = b.counts["uav1"]
    assert (counts["positions_without_fix"], counts["bad_telemetry"]) == (3, 0)
    assert sum("no GPS fix yet" in r.getMessage() for r in caplog.records) == 1
    assert b.vehicles["uav1"].telemetry.position_enu_m is None  # nothing to publish from
    assert b.ingest("uav1", global_position(100.0, 200.0, 150.0), 0.4)
