"""Where a sensor's field meets the ground, and the false detections (clutter) drawn inside it.

Shared by the simulated vehicles' scans (:mod:`sim_vehicles.scene`) and the many-target
benches' (:mod:`sim_vehicles.truth.detections`); numpy alone, so the simulator starts
without the estimators' imports.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["clutter_points", "ground_disc_radius"]


def ground_disc_radius(vehicle_xyz: NDArray[np.float64], max_range_m: float, target_height_m: float) -> NDArray[np.float64]:
    """Horizontal radius (V,) of the ground disc within slant range ``max_range_m`` of each vehicle (V, 3); 0 if out of reach."""
    dz = vehicle_xyz[:, 2] - target_height_m
    return np.sqrt(np.maximum(max_range_m**2 - dz * dz, 0.0))


def clutter_points(centre_xy: NDArray[np.float64], radius_m: float, rate: float,
                   rng: np.random.Generator) -> NDArray[np.float64]:
    """``Poisson(rate)`` false-detection points (k, 2), uniform over the disc of ``radius_m`` about ``centre_xy``.

    Uniform over the disc: radius ``R sqrt(u)`` with ``u ~ U(0, 1)`` (the area within ``r`` grows
    as ``r^2``), bearing uniform in [-pi, pi). Draws ``poisson``, then ``k`` uniforms, then ``k`` bearings.
    """
    k = rng.poisson(rate)
    r, bearing = radius_m * np.sqrt(rng.random(k)), rng.uniform(-np.pi, np.pi, k)
    return np.asarray(centre_xy, dtype=np.float64)[:2] + np.column_stack([r * np.cos(bearing), r * np.sin(bearing)])
