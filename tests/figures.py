"""Independent figures that test results are held against: what physics allows, computed from a scenario."""

from __future__ import annotations

import math

import numpy as np

from gcs.config import Scenario

__all__ = ["track_error_window", "one_scan_bound_m"]


def track_error_window(scenario: Scenario) -> tuple[float, float]:
    """``(floor, ceiling)`` of a fused track's position RMSE, metres.

    Floor: the target's own motion over one step, the white acceleration's position spread
    ``sqrt(q T^3 / 3)``: no track can be closer. Ceiling: the error of one raw detection from the lowest UAV,
    range noise along the line of sight and elevation noise times the height across it: fusion must beat it.
    """
    floor = math.sqrt(scenario.target.accel_psd_m2_s3 * scenario.time.step_s**3 / 3.0)
    lowest = min(v.altitude_m for v in scenario.vehicles)
    return floor, math.hypot(scenario.sensor.range_std_m, lowest * scenario.sensor.elevation_std_rad)


def one_scan_bound_m(scenario: Scenario) -> float:
    """RMS position error no estimator beats with one scan of bearings from the scenario's start positions:
    ``sqrt(trace(J^-1))``, ``J = sum_i u_i u_i^T / (sigma_i r_i)^2`` with ``u_i`` across UAV i's line of sight
    and ``sigma_i`` zuo2021 eq. (2)'s noise at its range."""
    target, sensor = np.asarray(scenario.target.start_enu_m), scenario.sensor
    information = np.zeros((2, 2))
    for vehicle in scenario.vehicles:
        offset = target - np.asarray(vehicle.start_enu_m)
        distance = float(np.hypot(*offset))
        std = sensor.azimuth_std_rad * max(distance / sensor.reference_range_m, 1.0)
        across = np.array([-offset[1], offset[0]]) / distance
        information += np.outer(across, across) / (std * distance) ** 2
    return float(np.sqrt(np.trace(np.linalg.inv(information))))
