"""The simulator's scans of several targets: detection probability, clutter, several targets, the side-by-side pair.

Each figure is checked against an independent one: the binomial and Poisson laws the configuration
states, the mean distance of a point uniform over a disc (2R/3), line of sight computed here, and the
scenario's own scripted paths.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest

from gcs.config import ScenarioError, TargetConfig
from gcs.config.world import build_world
from gcs.core.world.los import line_of_sight
from gcs.scenarios import load_scenario, parse_scenario
from sim_vehicles.scene import Scene
from sim_vehicles.truth.fixed_wing import AirframeState

URBAN = load_scenario("wang2012_urban")
WORLD = build_world(URBAN)
MULTI = load_scenario("multitarget_urban")
MULTI_WORLD = build_world(MULTI)


def _scenario(pd: float, clutter: float, **changes) -> object:
    sensor = msgspec.structs.replace(URBAN.sensor, detection_probability=pd, clutter_rate=clutter)
    return msgspec.structs.replace(URBAN, sensor=sensor, **changes)


def _hold(scene: Scene, vehicle_id: str, xyz) -> np.ndarray:
    """Put the vehicle (truth and its own navigation) at ``xyz``."""
    vehicle = scene.vehicles[vehicle_id]
    vehicle.state = AirframeState(np.array(xyz, dtype=np.float64), 0.0, 0.0, 25.0)
    vehicle.nav_position_enu_m = np.array(xyz, dtype=np.float64)
    return vehicle.state.position_enu_m


def _ground_points(report) -> np.ndarray:
    """Where each detection puts its object on the ground (ENU, m), by inverting range/azimuth/elevation."""
    x, y, _ = report.vehicle_position_enu_m
    out = []
    for d in report.detections:
        ground = d.range_m * math.cos(d.elevation_rad)
        out.append((x + ground * math.cos(d.azimuth_rad), y + ground * math.sin(d.azimuth_rad)))
    return np.array(out).reshape(-1, 2)


def test_the_detection_rate_is_the_detection_probability_within_a_binomial_bound() -> None:
    pd, scans = 0.7, 3000
    scene = Scene(_scenario(pd, 0.0), WORLD, seed=21)
    target = scene.target_xyz
    above = _hold(scene, "uav1", (target[0] + 30.0, target[1], 200.0))
    assert line_of_sight(WORLD.buildings, target[None], above[None])[0]  # in sight, in range: only pd decides
    counts = [len(scene.sensor_report("uav1").detections) for _ in range(scans)]
    assert set(counts) <= {0, 1}
    sigma = math.sqrt(scans * pd * (1 - pd))
    assert abs(sum(counts) - scans * pd) < 4 * sigma, (sum(counts), scans * pd, sigma)


def test_the_clutter_count_is_poisson_with_the_rate_and_uniform_over_the_ground_in_the_field() -> None:
    rate, scans = 2.5, 2000
    scene = Scene(_scenario(0.0, rate), WORLD, seed=22)  # pd = 0: every detection is a false alarm
    vehicle = _hold(scene, "uav2", (1500.0, 1500.0, 200.0))
    reports = [scene.sensor_report("uav2") for _ in range(scans)]
    counts = np.array([len(r.detections) for r in reports])
    assert abs(counts.mean() - rate) < 4 * math.sqrt(rate / scans)
    assert abs(counts.var() - rate) < 0.5  # Poisson: variance = mean (a fixed count would give 0)
    radius = math.sqrt(URBAN.sensor.max_range_m**2 - 200.0**2)
    distance = np.concatenate([np.hypot(*(_ground_points(r) - vehicle[:2]).T) for r in reports])
    assert distance.max() < radius + 5 * 10.0  # in the field, up to the range noise
    se = radius * math.sqrt(1 / 2 - 4 / 9) / math.sqrt(len(distance))  # sd of r for r uniform over a disc
    assert abs(distance.mean() - 2 * radius / 3) < 5 * se + 5.0


def test_with_certain_detection_every_target_in_sight_is_reported_once_without_identity() -> None:
    scenario = msgspec.structs.replace(MULTI, sensor=msgspec.structs.replace(
        MULTI.sensor, detection_probability=1.0, clutter_rate=0.0))
    scene = Scene(scenario, MULTI_WORLD, seed=5)
    several = 0
    for _ in range(40):
        for _ in range(20):
            scene.advance(0.05, {})
        truths = np.array([t.position_enu_m for t in scene.truths()])
        for vehicle_id, vehicle in scene.vehicles.items():
            report = scene.sensor_report(vehicle_id)
            xyz = vehicle.state.position_enu_m
            targets = np.column_stack([truths, np.zeros(len(truths))])
            in_sight = line_of_sight(MULTI_WORLD.buildings, targets, np.broadcast_to(xyz, targets.shape))
            assert len(report.detections) == int(in_sight.sum())
            several += len(report.detections) >= 2
            seen = _ground_points(report)
            for point in truths[in_sight]:  # each one near some detection (noise: 10 m, 0.05 rad at 200-3000 m)
                assert np.hypot(*(seen - point).T).min() < 0.2 * np.hypot(*(point - xyz[:2])) + 60.0
            assert not hasattr(report.detections[0] if report.detections else None, "target_id")
    assert several > 20


def test_the_multitarget_scenario_has_five_street_targets_two_side_by_side_for_more_than_20_s() -> None:
    assert [t.id for t in MULTI.all_targets] == ["car1", "car2", "car3", "pair_north", "pair_south"]
    assert MULTI.sensor.detection_probability == 0.9 and MULTI.sensor.clutter_rate > 0.0
    scene = Scene(MULTI, MULTI_WORLD, seed=1)
    gaps, positions = [], []
    for _ in range(150):
        for _ in range(20):
            scene.advance(0.05, {})
        truths = {t.target_id: np.array(t.position_enu_m) for t in scene.truths()}
        positions.append(np.stack(list(truths.values())))
        gaps.append(float(np.linalg.norm(truths["pair_north"] - truths["pair_south"])))
    close, longest = 0, 0
    for gap in gaps:
        close = close + 1 if gap <= 15.0 else 0
        longest = max(longest, close)
    assert longest >= 20  # seconds (one truth a second)
    assert max(gaps) > 300.0  # and then they part
    assert MULTI_WORLD.streets.on_street(np.concatenate(positions)).all()
    moved = np.linalg.norm(positions[-1] - positions[0], axis=1)
    assert (moved > 50.0).all()  # every car drives


def test_a_scan_of_the_multitarget_scenario_misses_some_targets_and_adds_clutter() -> None:
    scene = Scene(MULTI, MULTI_WORLD, seed=9)
    reported, in_sight = 0, 0
    for _ in range(60):
        for _ in range(20):
            scene.advance(0.05, {})
        truths = np.array([t.position_enu_m for t in scene.truths()])
        targets = np.column_stack([truths, np.zeros(len(truths))])
        for vehicle_id, vehicle in scene.vehicles.items():
            xyz = vehicle.state.position_enu_m
            in_sight += int(line_of_sight(MULTI_WORLD.buildings, targets, np.broadcast_to(xyz, targets.shape)).sum())
            reported += len(scene.sensor_report(vehicle_id).detections)
    clutter = 60 * 3 * MULTI.sensor.clutter_rate
    expected = 0.9 * in_sight + clutter
    spread = math.sqrt(in_sight * 0.9 * 0.1 + clutter)
    assert abs(reported - expected) < 4 * spread, (reported, expected, spread)


def test_extra_targets_get_their_own_streams_and_leave_the_first_targets_alone() -> None:
    extra = TargetConfig(id="other", motion="streets", start_enu_m=(600.0, 600.0))
    one = Scene(URBAN, WORLD, seed=3)
    two = Scene(msgspec.structs.replace(URBAN, targets=[extra]), WORLD, seed=3)
    for _ in range(100):
        one.advance(0.05, {})
        two.advance(0.05, {})
    assert np.array_equal(one.target.position, two.target.position)
    assert [t.target_id for t in two.truths()] == ["target", "other"]
    assert [t.seq for t in two.truths()] == [2, 2]


@pytest.mark.parametrize(("extra", "words"), [
    ('[[targets]]\nid = "target"\n', "duplicate target id 'target'"),
    ('[[targets]]\nid = "b"\nmotion = "scripted"\n', "$.targets[0].path_file: required"),
    ('[[targets]]\nid = "b"\nstart_enu_m = [-5.0, 10.0]\n', "$.targets[0].start_enu_m"),
    ('[[targets]]\nid = "b"\nmotion = "scripted"\npath_file = "p.csv"\npath = [[0.0, 1.0, 2.0]]\n',
     "$.targets[0].path: give path_file or path"),
    ('[[targets]]\nid = "b"\nmotion = "scripted"\npath = [[0.0, 1.0, 2.0], [0.0, 3.0, 2.0]]\n',
     "$.targets[0].path: the times t_s must be strictly increasing"),
])
def test_bad_targets_are_rejected_naming_the_key(extra: str, words: str) -> None:
    text = 'name = "t"\n[origin]\nlat_deg = 0.0\nlon_deg = 0.0\nheight_m = 0.0\n' \
           '[[vehicles]]\nid = "u"\nsysid = 1\naltitude_m = 200.0\nspeed_mps = 25.0\n' \
           'max_turn_rate_rad_s = 0.2\nstart_enu_m = [100.0, 100.0]\n' + extra
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text)
    assert words in str(info.value)


def test_sensor_detection_settings_are_bounded() -> None:
    with pytest.raises(ScenarioError, match="detection_probability"):
        parse_scenario('name = "t"\n[origin]\nlat_deg = 0.0\nlon_deg = 0.0\nheight_m = 0.0\n'
                       '[sensor]\ndetection_probability = 1.5\n'
                       '[[vehicles]]\nid = "u"\nsysid = 1\naltitude_m = 200.0\nspeed_mps = 25.0\n'
                       'max_turn_rate_rad_s = 0.2\nstart_enu_m = [100.0, 100.0]\n')
