"""The single-target fusion given reports of several detections: which one it takes, and why.

The expected choice is worked out here from the geometry (exact range/azimuth/elevation written out with
``math``) and the stated rule (least squared Mahalanobis distance to the track; before a track, the first
detection of the first vehicle, then the nearest to the track that starts from it).
"""

from __future__ import annotations

import math

import numpy as np

from gcs.core.filters.uif import GaussianEstimate
from gcs.engine.fusion import fuse_step, step_detections
from gcs.engine.steps import ReadyStep
from gcs.engine.tracker_factory import tracker_config
from gcs.scenarios import load_scenario
from protocols.messages import Measurement, SensorReport

SCENARIO = load_scenario("wang2012_urban")
CONFIG = tracker_config(SCENARIO, None, "ga_k5")
ROSTER = ["uav1", "uav2", "uav3"]
S = 1_000_000_000


def _seen(vehicle_xyz, point_xy) -> Measurement:
    """The exact measurement of a ground point from a vehicle (ENU m), with the scenario's sensor noise."""
    dx, dy, dz = point_xy[0] - vehicle_xyz[0], point_xy[1] - vehicle_xyz[1], -vehicle_xyz[2]
    ground = math.hypot(dx, dy)
    return Measurement(range_m=math.hypot(ground, dz), range_std_m=10.0, azimuth_rad=math.atan2(dy, dx),
                       azimuth_std_rad=0.05, elevation_rad=math.atan2(dz, ground), elevation_std_rad=0.05)


def _report(vehicle_id: str, xyz, *points) -> SensorReport:
    return SensorReport(vehicle_id=vehicle_id, seq=1, stamp_ns=S, vehicle_position_enu_m=xyz,
                        detections=tuple(_seen(xyz, p) for p in points))


def _values(m: Measurement) -> list[float]:
    return [m.range_m, m.azimuth_rad, m.elevation_rad]


def _track(x: float, y: float, var_x: float, var_y: float) -> GaussianEstimate:
    return GaussianEstimate(np.array([x, y, 0.0, 0.0]), np.diag([var_x, var_y, 1.0, 1.0]), S)


def test_of_several_detections_the_one_nearest_the_track_is_taken_whatever_the_order() -> None:
    xyz = (1000.0, 700.0, 200.0)
    near, far = (1020.0, 1010.0), (1400.0, 1300.0)
    track = _track(1000.0, 1000.0, 400.0, 400.0)
    for order in ((far, near), (near, far)):
        (d,) = step_detections(ReadyStep(1, S, (_report("uav1", xyz, *order),)), ROSTER, CONFIG, estimate=track)
        assert d.values.tolist() == _values(_seen(xyz, near))


def test_the_choice_is_by_mahalanobis_distance_not_by_metres() -> None:
    # The track is sure of y (1 m) and unsure of x (100 m): 150 m along x is closer than 40 m along y.
    xyz = (1000.0, 700.0, 200.0)
    along_x, along_y = (1150.0, 1000.0), (1000.0, 1040.0)
    assert math.dist(along_x, (1000.0, 1000.0)) > math.dist(along_y, (1000.0, 1000.0))
    track = _track(1000.0, 1000.0, 100.0**2, 1.0)
    (d,) = step_detections(ReadyStep(1, S, (_report("uav1", xyz, along_y, along_x),)), ROSTER, CONFIG,
                           estimate=track)
    assert d.values.tolist() == _values(_seen(xyz, along_x))


def test_before_a_track_the_first_vehicles_first_detection_starts_it_and_the_others_follow_it() -> None:
    target, clutter = (1500.0, 1500.0), (600.0, 2400.0)
    one, two, three = (1200.0, 1200.0, 200.0), (1800.0, 1200.0, 210.0), (1500.0, 1900.0, 220.0)
    reports = (_report("uav2", two, clutter, target), _report("uav1", one, target, clutter),
               _report("uav3", three, target))
    first, second, third = step_detections(ReadyStep(1, S, reports), ROSTER, CONFIG)
    assert [d.vehicle for d in (first, second, third)] == [0, 1, 2]  # roster order
    assert first.values.tolist() == _values(_seen(one, target))  # uav1 listed the target first
    assert second.values.tolist() == _values(_seen(two, target))  # uav2 listed clutter first: not taken
    assert third.values.tolist() == _values(_seen(three, target))
    estimate, used = fuse_step(CONFIG, None, ReadyStep(1, S, reports), ROSTER)
    assert len(used) == 3 and math.dist(estimate.mean[:2], target) < 5.0  # exact data: the track is on it


def test_a_track_is_followed_through_clutter_over_steps() -> None:
    rng = np.random.default_rng(17)
    vehicles = {"uav1": (1200.0, 1200.0, 200.0), "uav2": (1800.0, 1200.0, 210.0), "uav3": (1500.0, 1900.0, 220.0)}
    estimate = None
    for k in range(1, 21):
        target = (1500.0 + 5.0 * k, 1500.0)
        reports = []
        for vehicle_id, xyz in vehicles.items():
            points = [target] + [tuple(rng.uniform(500.0, 2500.0, 2)) for _ in range(int(rng.integers(0, 4)))]
            order = rng.permutation(len(points))
            if k == 1 and vehicle_id == "uav1":  # the track starts from uav1's first detection: the target
                order = np.array([0, *[i for i in order if i != 0]])
            reports.append(SensorReport(vehicle_id=vehicle_id, seq=k, stamp_ns=k * S, vehicle_position_enu_m=xyz,
                                        detections=tuple(_seen(xyz, points[i]) for i in order)))
        estimate, used = fuse_step(CONFIG, estimate, ReadyStep(k, k * S, tuple(reports)), ROSTER)
        assert len(used) == 3
        assert math.dist(estimate.mean[:2], target) < 10.0, (k, estimate.mean[:2], target)
