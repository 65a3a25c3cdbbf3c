"""The single-target tracker as a :class:`~gcs.core.target_tracker.TargetTracker`: one estimate, and of each
vehicle's detections the one nearest it.

A scan fuses at most one detection from each vehicle (:func:`choose_detections`): the only
one when there is one; of several, the one nearest the track in squared Mahalanobis distance
(:func:`choose_measurement`). Before a track exists, the scan starts one from the first
detection of the first vehicle that has one (the order the vehicle listed them in), and
every other vehicle's detection is chosen against that start. The chosen detections go to
:func:`gcs.core.tracker.fuse` (the DUIF, wang2012 eq. 14-15; the IMM or zuo2021's VG-UKF when
the tracker is configured so). The scan is deterministic: the same estimate and detections
give the same result bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.uif import GaussianEstimate
from gcs.core.models.sensor import RANGE, SensorModel
from gcs.core.multitarget.filter import innovations
from gcs.core.target_tracker import DetectionsByVehicle, InView
from gcs.core.tracker import Detection, Sensing, TrackerConfig, fuse, initial_estimate

__all__ = ["SingleTargetTracker", "SingleTargetScan", "choose_detections", "choose_measurement"]


@dataclass(frozen=True)
class SingleTargetScan:
    """What one scan fused: the chosen detections, in the vehicles' order."""

    detections: tuple[Detection, ...]


@dataclass(frozen=True)
class SingleTargetTracker:
    """The tracker of one target (see the module docstring); ``config`` holds its filters, never the estimate."""

    config: TrackerConfig

    def start(self) -> GaussianEstimate | None:
        """No estimate before the first detection."""
        return None

    def scan(self, state: GaussianEstimate | None, stamp_ns: int, detections_by_vehicle: DetectionsByVehicle,
             sensors: Sequence[SensorModel], in_view: InView | None = None, sensing: Sensing | None = None, /
             ) -> tuple[GaussianEstimate | None, SingleTargetScan]:
        """The estimate after one scan, and the detections fused (``in_view`` is not used: one target's track is
        never deleted for a miss; ``sensing``, every vehicle that sensed, gives the road tracker its negative
        information). Raises what :func:`~gcs.core.tracker.fuse` raises on absurd data."""
        config = self.config if sensors is self.config.sensors else replace(self.config, sensors=tuple(sensors))
        detections = choose_detections(config, state, stamp_ns, detections_by_vehicle)
        return fuse(config, state, stamp_ns, detections, sensing), SingleTargetScan(detections)


def choose_detections(config: TrackerConfig, estimate: GaussianEstimate | None, stamp_ns: int,
                      detections_by_vehicle: DetectionsByVehicle) -> tuple[Detection, ...]:
    """One detection of each vehicle that has any, in the vehicles' order: the only one, or the one
    :func:`choose_measurement` picks against ``estimate`` (the track before this scan) predicted to the scan;
    without a track, against the track the scan starts from its first detection (the first vehicle's first),
    or the first detection when that start needs a range the sensor does not measure."""
    chosen: list[Detection] = []
    track = None
    for vehicle, found in detections_by_vehicle.items():
        if not found:
            continue
        detection = found[0]
        if len(found) > 1:
            if track is None:
                track = _track_now(config, estimate, stamp_ns)
            if track is None and chosen:
                track = _seed_track(config, chosen[0], stamp_ns)
            if track is not None:
                detection = found[choose_measurement([d.values for d in found], config.sensors[vehicle], track,
                                                     detection.vehicle_xyz, detection.position_cov)]
        chosen.append(detection)
    return tuple(chosen)


def choose_measurement(candidates: Sequence[NDArray[np.float64]], sensor: SensorModel, track: GaussianEstimate,
                       vehicle_xyz: NDArray[np.float64], vehicle_cov: NDArray[np.float64]) -> int:
    """Index of the candidate measurement nearest the track: least ``nu^T S^-1 nu``.

    ``nu = z - h(x)`` is the innovation (azimuth wrapped) about the track's mean position and
    ``S = H P H^T + R + J_s P_s J_s^T`` its covariance, with the track's position covariance
    ``P``, the sensor's noise ``R`` and the vehicle's position covariance ``P_s`` (3, 3) carried
    through ``J_s = dh/dp_s`` (:func:`gcs.core.multitarget.filter.innovations`). This is
    nearest-neighbour association (Bar-Shalom, Willett & Tian, *Tracking and Data Fusion*,
    2011, section 3.2); ties go to the earlier candidate.
    """
    z = np.stack(candidates)
    n = len(z)
    inn = innovations(track.mean[None, :], track.cov[None, :, :], sensor, z,
                      np.broadcast_to(vehicle_xyz, (n, 3)), np.broadcast_to(vehicle_cov, (n, 3, 3)))
    return int(np.argmin(inn.d2[0]))


def _track_now(config: TrackerConfig, estimate: GaussianEstimate | None, stamp_ns: int) -> GaussianEstimate | None:
    """The track predicted to the scan (as :func:`~gcs.core.tracker.fuse` will), to choose among a vehicle's
    detections.

    Predicted as a plain Gaussian of its mean and covariance, so an IMM estimate (a
    :class:`~gcs.core.filters.imm_target.ImmEstimate`) is taken as its moment-matched whole."""
    if estimate is None or estimate.dim != config.uif.motion.dim or stamp_ns < estimate.stamp_ns:
        return estimate
    return config.uif.predict(GaussianEstimate(estimate.mean, estimate.cov, estimate.stamp_ns,
                                               layout=estimate.layout), stamp_ns)


def _seed_track(config: TrackerConfig, seed: Detection, stamp_ns: int) -> GaussianEstimate | None:
    """The track a scan starts from its first detection (:func:`~gcs.core.tracker.initial_estimate`); None
    without a range."""
    sensor = config.sensors[seed.vehicle]
    if config.bearing_filter is not None or RANGE not in sensor.components:
        return None
    return initial_estimate(seed, sensor, stamp_ns, config.initial_position_std_m,
                            config.initial_velocity_std_mps, config.uif.motion.dim)
