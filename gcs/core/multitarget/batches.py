"""One scan's detections as arrays, one batch per vehicle: what the trackers associate."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.models.sensor import SensorModel
from gcs.core.tracker import Detection

__all__ = ["DetectionBatch", "detection_batches"]


@dataclass(frozen=True)
class DetectionBatch:
    """One vehicle's detections as arrays: measurements (n, m), where each was taken from (n, 3) and that position's
    covariance (n, 3, 3)."""

    vehicle: int
    sensor: SensorModel
    z: NDArray[np.float64]
    xyz: NDArray[np.float64]
    pcov: NDArray[np.float64]


def detection_batches(detections_by_vehicle: Mapping[int, Sequence[Detection]] | Sequence[Sequence[Detection]],
                      sensor: SensorModel | Sequence[SensorModel]) -> list[DetectionBatch]:
    """Each vehicle's non-empty detection list as arrays."""
    groups = detections_by_vehicle.values() if isinstance(detections_by_vehicle, Mapping) else detections_by_vehicle
    out = []
    for group in groups:
        group = list(group)
        if not group:
            continue
        if not all(isinstance(d, Detection) for d in group):
            raise TypeError("detections must be gcs.core.tracker.Detection")
        vehicle = group[0].vehicle
        model = sensor if isinstance(sensor, SensorModel) else sensor[vehicle]
        z = np.array([d.values for d in group], dtype=np.float64)
        if z.shape[1] != model.dim:
            raise ValueError(f"vehicle {vehicle}'s detections have {z.shape[1]} components, its sensor {model.dim}")
        xyz = np.array([d.vehicle_xyz for d in group], dtype=np.float64)
        pcov = np.stack([d.position_cov for d in group])
        out.append(DetectionBatch(vehicle, model, z, xyz, pcov))
    return out
