"""A recording of three tracks (``t1``, ``t2``, ``t3``) of ``multitarget_urban``, written message by message, for the map's tests.

Eight decision steps, one a second: the three UAVs' sensor reports (received 0-20 ms
after their stamp) and the tracks the daemon would publish on ``gcs/track/t<n>``
(100 ms after their step), each with a covariance, a three-point prediction and its
contributing vehicles.

- ``t1`` drives east from (900, 1500) at 10 m/s; uav1 and uav2 contribute.
- ``t3`` drives beside it, 8 m to the north (two cars in the two lanes of a street,
  a pixel or two apart on the map); nobody contributes (predicted only).
- ``t2`` drives north from (2100, 800) at 8 m/s; uav1 contributes.
- uav3 detects something every scan but contributes to none (clutter: it has no sight line).
"""

from __future__ import annotations

import math
from pathlib import Path

from gcs.adapters.recording import Recorder
from protocols.codec import encode
from protocols.keys import alive_key, report_key, track_key
from protocols.messages import PredictedPoint, TrackEstimate
from protocols.sensor_report import Measurement, SensorReport

__all__ = ["SCENARIO_NAME", "STEPS", "UAVS", "tracks_recording"]

SCENARIO_NAME = "multitarget_urban"
NS = 1_000_000_000
EPOCH_NS = 1_700_000_000 * NS
STEPS = 8
UAVS = {"uav1": (1200.0, 1200.0, 200.0), "uav2": (1800.0, 1200.0, 210.0), "uav3": (2400.0, 1000.0, 220.0)}
"""Where each UAV starts (ENU m); they fly east at 20 m/s."""
TARGETS = {  # id: start (m), velocity (m/s), position covariance (m^2), contributing vehicles
    "t1": ((900.0, 1500.0), (10.0, 0.0), ((100.0, 30.0), (30.0, 49.0)), ("uav1", "uav2")),
    "t2": ((2100.0, 800.0), (0.0, 8.0), ((36.0, 0.0), (0.0, 144.0)), ("uav1",)),
    "t3": ((900.0, 1508.0), (10.0, 0.0), ((64.0, 0.0), (0.0, 64.0)), ()),
}


def _track(target_id: str, k: int) -> TrackEstimate:
    (x0, y0), (vx, vy), ((a, b), (_, c)), contributing = TARGETS[target_id]
    stamp = EPOCH_NS + k * NS
    x, y = x0 + vx * k, y0 + vy * k
    covariance = (a, b, 0.0, 0.0, b, c, 0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, 4.0)
    prediction = tuple(PredictedPoint(stamp_ns=stamp + j * NS, position_enu_m=(x + vx * j, y + vy * j),
                                      position_cov_m2=(a + 4.0 * j * j, b, b, c + 4.0 * j * j)) for j in (1, 2, 3))
    return TrackEstimate(target_id=target_id, seq=k + 1, stamp_ns=stamp, model="cv2d", state=(x, y, vx, vy),
                         covariance=covariance, contributing_vehicles=contributing, prediction=prediction)


def _report(vehicle_id: str, k: int) -> SensorReport:
    x, y, z = UAVS[vehicle_id]
    seen = Measurement(range_m=500.0, range_std_m=10.0, azimuth_rad=0.3, azimuth_std_rad=0.05,
                       elevation_rad=-math.asin(z / 500.0), elevation_std_rad=0.05)
    return SensorReport(vehicle_id=vehicle_id, seq=k + 1, stamp_ns=EPOCH_NS + k * NS,
                        vehicle_position_enu_m=(x + 20.0 * k, y, z), detections=(seen,))


def tracks_recording(path: Path) -> dict[str, TrackEstimate]:
    """Write the recording to ``path``; the last track of each target, by id."""
    last: dict[str, TrackEstimate] = {}
    with Recorder(path) as recorder:
        for vehicle_id in UAVS:
            recorder.write_liveliness(alive_key(vehicle_id), True, EPOCH_NS - NS // 2)
        for k in range(STEPS):
            stamp = EPOCH_NS + k * NS
            for slot, vehicle_id in enumerate(UAVS):
                recorder.write_heartbeat(alive_key(vehicle_id), stamp - NS // 2)  # as the daemon records them
                recorder.write(report_key(vehicle_id), *encode(_report(vehicle_id, k)), stamp + slot * 10_000_000)
            for target_id in TARGETS:
                last[target_id] = _track(target_id, k)
                recorder.write(track_key(target_id), *encode(last[target_id]), stamp + 100_000_000)
    return last
