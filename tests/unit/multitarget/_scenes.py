"""Scenes for the tracker tests: ground targets, vehicles and their detections, made by the tests' own formulas
(not the filter's ``h(x)``, docs/design.md, the layers)."""

from __future__ import annotations

import math

import numpy as np

from gcs.core.tracker import Detection

RANGE_MAX_M = 4000.0
CLUTTER_VOLUME = RANGE_MAX_M * 2.0 * math.pi * (math.pi / 2.0)
"""Measurement-space volume the clutter is spread over: range x azimuth x (downward) elevation, m rad^2."""


def range_azimuth_elevation(target_xy: np.ndarray, vehicle_xyz: np.ndarray, height_m: float = 0.0) -> np.ndarray:
    """Range, azimuth (from east, counter-clockwise) and elevation of a ground point seen from a vehicle."""
    dx, dy = target_xy[0] - vehicle_xyz[0], target_xy[1] - vehicle_xyz[1]
    dz = height_m - vehicle_xyz[2]
    horizontal = math.hypot(dx, dy)
    return np.array([math.sqrt(horizontal**2 + dz**2), math.atan2(dy, dx), math.atan2(dz, horizontal)])


def scan_detections(rng: np.random.Generator | None, targets: np.ndarray, vehicles: np.ndarray, std: np.ndarray,
                    detection_probability: float = 1.0, clutter_per_scan: float = 0.0) -> list[list[Detection]]:
    """Each vehicle's detections of the targets (T, 2): each detected with the probability, noisy by ``std``
    (zero noise without ``rng``), plus Poisson clutter uniform in the clutter volume; shuffled."""
    out = []
    for v, xyz in enumerate(vehicles):
        values = []
        for target in targets:
            if rng is not None and rng.random() >= detection_probability:
                continue
            z = range_azimuth_elevation(target, xyz)
            values.append(z if rng is None else z + rng.normal(size=3) * std)
        if rng is not None:
            for _ in range(rng.poisson(clutter_per_scan)):
                values.append(np.array([rng.uniform(0, RANGE_MAX_M), rng.uniform(-math.pi, math.pi),
                                        rng.uniform(-math.pi / 2, 0.0)]))
            values = [values[k] for k in rng.permutation(len(values))]
        out.append([Detection(v, xyz.copy(), value) for value in values])
    return out


def cv_truth(rng: np.random.Generator, start: np.ndarray, steps: int, dt_s: float, accel_psd: float) -> np.ndarray:
    """States (steps, T, 4) of targets following the white-noise acceleration CV model from ``start`` (T, 4)."""
    f = np.kron(np.array([[1.0, dt_s], [0.0, 1.0]]), np.eye(2))
    q = accel_psd * np.kron(np.array([[dt_s**3 / 3, dt_s**2 / 2], [dt_s**2 / 2, dt_s]]), np.eye(2))
    root = np.linalg.cholesky(q)
    states = [start]
    for _ in range(steps - 1):
        states.append(states[-1] @ f.T + rng.normal(size=start.shape) @ root.T)
    return np.stack(states)
