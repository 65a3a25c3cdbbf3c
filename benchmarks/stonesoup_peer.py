"""Stone Soup's GNN and JPDA multi-target trackers as peers for the many-target bench, configured as ours.

Needs the ``peers`` extra (``pip install '.[peers]'``, Stone Soup 1.9).

**State and measurement.** The state is ``[x, vx, y, vy, z, vz]`` (ENU metres, m/s) with
Stone Soup's ``ConstantVelocity`` on every axis: white acceleration of spectral density
``process_noise`` (m^2/s^3) on x and y, none on z. Each detection is Stone Soup's
``CartesianToElevationBearingRange`` measurement (elevation, azimuth, slant range) with the
vehicle's position as ``translation_offset`` (azimuth ``atan2(dy, dx)`` from east,
counter-clockwise, elevation negative below the vehicle, as in :mod:`gcs.core.models.sensor`),
its noise the sensor model's variances (zuo2021 eq. 2 at the measured range when
``distance_dependent``), updated by the ``ExtendedKalmanUpdater``. A new track is
``SimpleMeasurementInitiator``'s inversion of one detection, put on the ground at the
sensor's ``target_height_m`` by a height pseudo-measurement
(:class:`~benchmarks.stonesoup_lifecycle.GroundInitiator`), its velocity spread
``prior_velocity_std_mps`` on x and y, none on z; z then stays at the ground. The
vehicles' position uncertainty (``Detection.vehicle_cov``) is not modelled.

**Several vehicles per scan.** Each vehicle's detections are fed to the tracker as their
own detection set at the scan's timestamp, one after the other (sequential updates; the
prediction to the same time is the identity): Stone Soup's associators take at most one
detection per track per set, so a target seen by three vehicles gets three updates per
scan. The lifecycle is counted in scans, not sets
(:mod:`benchmarks.stonesoup_lifecycle`): M-of-N confirmation over scans, deletion after
``max_missed_scans`` consecutive scans in which some UAV covered the track and none
detected it, or when the (x, y) covariance trace passes ``max_position_var_m2``. A vehicle
absent from a scan's dict counts as not having looked.

**Association.** Both peers use the ``PDAHypothesiser`` (detection probability ``pd``,
gate probability ``prob_gate``: the chi-square gate in the measurement's 3 dimensions,
clutter density ``clutter_density``): the JPDA as ``JPDA`` in a
``MultiTargetMixtureTracker``, the GNN as ``GNNWith2DAssignment`` (the most probable
joint assignment of the same likelihood ratios) in a ``MultiTargetTracker``. Tentative
tracks are associated with ``GNNWith2DAssignment`` on the same hypothesiser.

**Order.** Each detection is an :class:`~benchmarks.stonesoup_lifecycle.OrderedDetection`
hashed by (scan, vehicle, index), and each track numbered, so Stone Soup's sets iterate in
the same order on every run and a run is reproducible.
"""

from __future__ import annotations

import datetime
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

try:
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.dataassociator.probability import JPDA
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.initiator.simple import SimpleMeasurementInitiator
    from stonesoup.models.measurement.nonlinear import CartesianToElevationBearingRange
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
    from stonesoup.types.angle import Bearing, Elevation
    from stonesoup.types.array import StateVector
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater, KalmanUpdater

    from benchmarks.stonesoup_lifecycle import (CoveredMissDeleter, GroundInitiator, OrderedDetection, ScanClock,
                                                ScanInitiator)
except ImportError as exc:  # the optional peer: one clear line
    raise ImportError(f"the Stone Soup peers need Stone Soup: pip install '.[peers]' ({exc})") from None

from gcs.core.models.sensor import AZIMUTH, ELEVATION, RANGE, SensorModel
from gcs.core.tracker import Detection

__all__ = ["PeerConfig", "Peer", "PeerRun", "Scan", "measurement", "gnn_tracker", "jpda_tracker", "run_peer"]

Scan = tuple[int, dict[int, Sequence[Detection]], SensorModel, Callable | None]
"""One scan: ``(stamp_ns, {vehicle_index: [Detection, ...]}, sensor model, coverage)``; the coverage maps ground
positions (T, 2) to whether some UAV covered each (None: every track was covered)."""

_EPOCH = datetime.datetime(1970, 1, 1)


@dataclass(frozen=True)
class PeerConfig:
    """Parameters shared by both peers (see the module docstring); SI units.

    ``process_noise``: white-acceleration density per horizontal axis, m^2/s^3.
    ``prior_velocity_std_mps``: a new track's velocity spread. ``pd``, ``prob_gate``,
    ``clutter_density`` (false detections per m rad^2 of measurement space): the
    hypothesiser's. ``target_height_m``: the ground. ``confirm_m`` of ``confirm_n`` scans,
    ``max_missed_scans``, ``max_position_var_m2``: the lifecycle.
    """

    process_noise: float = 2.0
    prior_velocity_std_mps: float = 10.0
    pd: float = 0.9
    prob_gate: float = 0.99
    clutter_density: float = 1e-6
    target_height_m: float = 0.0
    confirm_m: int = 3
    confirm_n: int = 4
    max_missed_scans: int = 5
    max_position_var_m2: float = 2.0e4


@dataclass
class Peer:
    """A Stone Soup tracker and the scan clock its lifecycle reads."""

    tracker: MultiTargetTracker | MultiTargetMixtureTracker
    clock: ScanClock


@dataclass(frozen=True)
class PeerRun:
    """A peer over a run: per scan its stamp, its confirmed tracks ``(track_id, x, y)`` and its wall time, seconds."""

    stamps_ns: tuple[int, ...]
    tracks: tuple[list[tuple[str, float, float]], ...]
    seconds: tuple[float, ...]


def measurement(detection: Detection, sensor: SensorModel) -> tuple[StateVector, np.ndarray]:
    """(elevation, azimuth, slant range) of one detection in Stone Soup's order, and its noise covariance (3, 3).

    Raises ValueError for a sensor that does not measure all three."""
    comps = sensor.components
    if set(comps) != {RANGE, AZIMUTH, ELEVATION}:
        raise ValueError(f"the Stone Soup peers need range, azimuth and elevation, got {comps}")
    values = np.asarray(detection.values, dtype=np.float64)
    rho, phi, theta = (values[comps.index(c)] for c in (RANGE, AZIMUTH, ELEVATION))
    vehicle = np.asarray(detection.vehicle_xyz, dtype=np.float64)
    ground = vehicle[:2] + rho * math.cos(theta) * np.array([math.cos(phi), math.sin(phi)])
    var = np.broadcast_to(sensor.noise_variance(values, ground, vehicle), (len(comps),))
    order = [comps.index(c) for c in (ELEVATION, AZIMUTH, RANGE)]
    return StateVector([Elevation(theta), Bearing(phi), rho]), np.diag(var[order])


def _stone_soup_detections(detections: Sequence[Detection], sensor: SensorModel, when: datetime.datetime,
                           scan: int, vehicle: int) -> set[OrderedDetection]:
    out = set()
    for index, det in enumerate(detections):
        vector, noise = measurement(det, sensor)
        model = CartesianToElevationBearingRange(
            ndim_state=6, mapping=(0, 2, 4), noise_covar=noise,
            translation_offset=StateVector(np.asarray(det.vehicle_xyz, dtype=float)))
        out.add(OrderedDetection(vector, timestamp=when, measurement_model=model,
                                 metadata={"order": (scan, vehicle, index)}))
    return out


def _parts(config: PeerConfig):
    """Updater, hypothesiser, deleter, initiator and scan clock common to both peers."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(config.process_noise)] * 2
                                                       + [ConstantVelocity(0.0)])
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)  # every detection carries its own model
    hypothesiser = PDAHypothesiser(predictor, updater, clutter_spatial_density=config.clutter_density,
                                   prob_detect=config.pd, prob_gate=config.prob_gate)
    v2 = config.prior_velocity_std_mps**2
    prior = GaussianState(np.zeros((6, 1)), np.diag([0.0, v2, 0.0, v2, 0.0, 0.0]))
    clock = ScanClock()
    deleter = CoveredMissDeleter(clock=clock, max_misses=config.max_missed_scans,
                                 max_position_var_m2=config.max_position_var_m2)
    ground = GroundInitiator(initiator=SimpleMeasurementInitiator(prior_state=prior, measurement_model=None),
                             updater=KalmanUpdater(measurement_model=None), target_height_m=config.target_height_m)
    initiator = ScanInitiator(clock=clock, initiator=ground, data_associator=GNNWith2DAssignment(hypothesiser),
                              updater=updater, confirm_m=config.confirm_m, confirm_n=config.confirm_n)
    return updater, hypothesiser, deleter, initiator, clock


def gnn_tracker(config: PeerConfig) -> Peer:
    """Global nearest neighbour: 2-D assignment on the PDA likelihood ratios, EKF updates."""
    updater, hypothesiser, deleter, initiator, clock = _parts(config)
    return Peer(MultiTargetTracker(initiator=initiator, deleter=deleter, detector=None,
                                   data_associator=GNNWith2DAssignment(hypothesiser), updater=updater), clock)


def jpda_tracker(config: PeerConfig) -> Peer:
    """Joint probabilistic data association: PDA hypotheses, joint events, moment-matched EKF updates."""
    updater, hypothesiser, deleter, initiator, clock = _parts(config)
    return Peer(MultiTargetMixtureTracker(initiator=initiator, deleter=deleter, detector=None,
                                          data_associator=JPDA(hypothesiser), updater=updater), clock)


def confirmed(peer: Peer) -> list[tuple[str, float, float]]:
    """The confirmed tracks ``(id, x, y)``, by id."""
    tracks = sorted(peer.tracker.tracks, key=lambda t: int(t.id))
    return [(t.id, float(t.state_vector[0, 0]), float(t.state_vector[2, 0])) for t in tracks]


def scan_peer(peer: Peer, scan: Scan, index: int) -> float:
    """Feed scan number ``index``, each vehicle's detections as its own set; the wall time it took, seconds
    (``time.perf_counter``; measured here, never asserted by tests)."""
    stamp_ns, per_vehicle, sensor, *rest = scan
    in_view = rest[0] if rest else None
    when = _EPOCH + datetime.timedelta(microseconds=stamp_ns / 1000.0)
    start = time.perf_counter()
    peer.clock.open(when, in_view)
    vehicles = sorted(per_vehicle)
    for vehicle in vehicles:
        peer.clock.closing = vehicle == vehicles[-1]
        peer.tracker.update_tracker(when, _stone_soup_detections(per_vehicle[vehicle], sensor, when, index, vehicle))
    return time.perf_counter() - start


def run_peer(peer: Peer, scans: Iterable[Scan]) -> PeerRun:
    """Feed the scans in time order (:func:`scan_peer`); the confirmed tracks after each, and its time."""
    stamps, tracks, seconds = [], [], []
    for index, scan in enumerate(scans):
        seconds.append(scan_peer(peer, scan, index))
        stamps.append(int(scan[0]))
        tracks.append(confirmed(peer))
    return PeerRun(tuple(stamps), tuple(tracks), tuple(seconds))
