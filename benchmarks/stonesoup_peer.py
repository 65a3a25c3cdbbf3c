"""Stone Soup's GNN and JPDA multi-target trackers as peers for the many-target bench.

Needs the ``peers`` extra (``pip install '.[peers]'``, Stone Soup 1.9).

**State layout.** The targets are on the ground at the sensor's known height
``target_height_m``, so the state is planar, ``[x, vx, y, vy]`` (ENU metres, m/s),
with Stone Soup's ``ConstantVelocity`` on each axis (white acceleration of spectral
density ``process_noise``, m^2/s^3). Each detection is turned into a ground
measurement, (azimuth, horizontal range), for ``CartesianToBearingRange`` with the
vehicle's (x, y) as ``translation_offset`` (azimuth ``atan2(dy, dx)`` from east,
counter-clockwise, as in :mod:`gcs.core.models.sensor`): with ``dz`` the vehicle's
height above the target, the horizontal range comes from the slant range,
``rho_h = sqrt(rho^2 - dz^2)``, standard deviation ``sigma_rho rho / rho_h``, and/or
from the elevation ``theta < 0``, ``rho_h = dz / tan(-theta)``, standard deviation
``dz sigma_theta / sin^2 theta`` (first order); when both are measured their
independent estimates are combined by inverse variance. This imposes the ground
constraint instead of estimating a height, and keeps the range's information
(far larger than the elevation's at these geometries). Distance-dependent noise
(zuo2021 eq. 2) is evaluated with the sensor model at the measured range. The
vehicles' position uncertainty (``Detection.vehicle_cov``) is not modelled by the peers.

**Several vehicles per scan.** Each vehicle's detections are fed to the tracker as
their own detection set at the scan's timestamp, one after the other (sequential
updates: the prediction to the same time is the identity), so a target seen by two
vehicles gets two updates per scan. The tracker, its deleter and its initiator
therefore count detection sets, not scans: ``max_missed_scans`` and
``tentative_missed_scans`` are converted to ``vehicles *`` as many sets; a vehicle
absent from a scan's dict counts as not having looked (give it an empty list when it
looked and saw nothing).

**Trackers.** GNN: ``GNNWith2DAssignment`` over a ``DistanceHypothesiser`` with the
Mahalanobis distance (gate ``gate_mahalanobis``), ``ExtendedKalmanUpdater``, in a
``MultiTargetTracker``. JPDA: ``JPDA`` over a ``PDAHypothesiser`` (``pd``, gate
probability, clutter density) in a ``MultiTargetMixtureTracker``. Both start tracks
with ``MultiMeasurementInitiator`` (M-of-N: ``min_points`` updates, tentative tracks
dropped after ``tentative_missed_scans`` without one; with two vehicles a target seen
at Pd 0.9 collects about 1.8 updates a scan) and delete confirmed tracks with a
``CompositeDeleter`` of ``CovarianceBasedDeleter`` (position covariance trace above
``max_position_var_m2``) or ``UpdateTimeStepsDeleter``. The clutter density for the
PDA is that of ``clutter_rate`` false detections per vehicle and scan spread over
the measurement space (azimuth in (-pi, pi], horizontal range in [0, R_h]) of the
ground disc of radius ``R_h`` in the sensor's field, ``clutter_rate / (2 pi R_h)``.
"""

from __future__ import annotations

import datetime
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

try:
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.dataassociator.probability import JPDA
    from stonesoup.deleter.error import CovarianceBasedDeleter
    from stonesoup.deleter.multi import CompositeDeleter
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
    from stonesoup.types.detection import Detection as SsDetection
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater
except ImportError as exc:  # the optional peer: one clear line
    raise ImportError(f"the Stone Soup peers need Stone Soup: pip install '.[peers]' ({exc})") from None

from gcs.core.models.sensor import ELEVATION, RANGE, SensorModel
from gcs.core.tracker import Detection

__all__ = ["PeerConfig", "PeerRun", "Scan", "clutter_density", "ground_measurement", "gnn_tracker", "jpda_tracker",
           "run_peer"]

Scan = tuple[int, dict[int, Sequence[Detection]], SensorModel]
"""One scan: ``(stamp_ns, {vehicle_index: [Detection, ...]}, sensor model)``."""

_EPOCH = datetime.datetime(1970, 1, 1)
_MIN_DEPRESSION_RAD = 1e-3
"""Elevations closer to the horizontal than this give no horizontal range."""


@dataclass(frozen=True)
class PeerConfig:
    """Parameters shared by both peers (see the module docstring); SI units.

    ``vehicles``: detection sets per scan. ``process_noise``: white-acceleration
    density per axis, m^2/s^3. ``prior_velocity_std_mps``: a new track's velocity
    spread. ``pd``, ``clutter_rate`` (per vehicle and scan), ``max_range_m`` and
    ``sensor_height_m`` (above the target): the JPDA's detection and clutter model.
    ``gate_mahalanobis``: the GNN's missed distance, also the tentative tracks' gate;
    ``prob_gate``: the PDA's gate probability. ``min_points``, ``tentative_missed_scans``:
    the M-of-N initiator. ``max_missed_scans`` and ``max_position_var_m2`` (trace of the
    (x, y) covariance): either deletes a confirmed track.
    """

    vehicles: int
    process_noise: float = 0.5
    prior_velocity_std_mps: float = 10.0
    pd: float = 0.9
    clutter_rate: float = 2.0
    max_range_m: float = 1500.0
    sensor_height_m: float = 300.0
    gate_mahalanobis: float = 4.0
    prob_gate: float = 0.99
    min_points: int = 5
    tentative_missed_scans: int = 2
    max_missed_scans: int = 5
    max_position_var_m2: float = 2.0e4


@dataclass(frozen=True)
class PeerRun:
    """A peer over a run: per scan its stamp, its confirmed tracks ``(track_id, x, y)`` and its wall time, seconds."""

    stamps_ns: tuple[int, ...]
    tracks: tuple[list[tuple[str, float, float]], ...]
    seconds: tuple[float, ...]


def ground_measurement(detection: Detection, sensor: SensorModel) -> tuple[float, float, float, float]:
    """(azimuth rad, horizontal range m, azimuth variance, horizontal-range variance) of one detection.

    Formulas in the module docstring; raises ValueError when the detection gives no
    horizontal range (azimuth only, or an elevation at or above the horizontal without range).
    """
    values = np.asarray(detection.values, dtype=np.float64)
    dz = float(detection.vehicle_xyz[2]) - sensor.target_height_m
    estimates = []  # (horizontal range, its variance)
    comps = sensor.components
    var0 = np.asarray(sensor.std, dtype=np.float64) ** 2  # at and inside the reference range
    if RANGE in comps:
        rho = values[comps.index(RANGE)]
        h = math.sqrt(max(rho * rho - dz * dz, 1.0))
        estimates.append((h, var0[comps.index(RANGE)] * (rho / h) ** 2, RANGE))
    if ELEVATION in comps and dz > 0 and values[comps.index(ELEVATION)] < -_MIN_DEPRESSION_RAD:
        theta = values[comps.index(ELEVATION)]
        estimates.append((dz / math.tan(-theta), var0[comps.index(ELEVATION)] * (dz / math.sin(theta) ** 2) ** 2,
                          ELEVATION))
    if not estimates:
        raise ValueError(f"a detection with components {comps} and values {values} gives no horizontal range")
    azimuth = values[sensor.azimuth_index]
    if sensor.distance_dependent:  # zuo2021 eq. (2): the variances at the measured (or estimated) range
        h0 = estimates[0][0]
        xy = np.asarray(detection.vehicle_xyz[:2]) + h0 * np.array([math.cos(azimuth), math.sin(azimuth)])
        scale = sensor.noise_variance(values, xy, np.asarray(detection.vehicle_xyz)) / var0
        estimates = [(h, v * scale[comps.index(c)], c) for h, v, c in estimates]
        az_var = float(var0[sensor.azimuth_index] * scale[sensor.azimuth_index])
    else:
        az_var = float(var0[sensor.azimuth_index])
    info = sum(1.0 / v for _, v, _ in estimates)
    h = sum(h / v for h, v, _ in estimates) / info  # inverse-variance combination of independent estimates
    return float(azimuth), float(h), az_var, float(1.0 / info)


def _stone_soup_detections(detections: Iterable[Detection], sensor: SensorModel,
                           when: datetime.datetime) -> set[SsDetection]:
    out = set()
    for det in detections:
        azimuth, h, az_var, h_var = ground_measurement(det, sensor)
        model = CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([az_var, h_var]),
                                        translation_offset=np.asarray(det.vehicle_xyz[:2], dtype=float).reshape(2, 1))
        out.add(SsDetection(np.array([[azimuth], [h]]), timestamp=when, measurement_model=model))
    return out


def _parts(config: PeerConfig):
    """Transition model, predictor, updater, Mahalanobis hypothesiser, prior and deleters common to both peers."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(config.process_noise)] * 2)
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)  # every detection carries its own model
    hypothesiser = DistanceHypothesiser(predictor, updater, measure=Mahalanobis(),
                                        missed_distance=config.gate_mahalanobis)
    v2 = config.prior_velocity_std_mps**2
    prior = GaussianState(np.zeros((4, 1)), np.diag([0.0, v2, 0.0, v2]))
    sets = config.vehicles * config.max_missed_scans  # the trackers count detection sets, one per vehicle
    tentative_sets = config.vehicles * config.tentative_missed_scans
    deleter = CompositeDeleter([CovarianceBasedDeleter(covar_trace_thresh=config.max_position_var_m2, mapping=[0, 2]),
                                UpdateTimeStepsDeleter(time_steps_since_update=sets)], intersect=False)
    initiator = MultiMeasurementInitiator(
        prior_state=prior, deleter=UpdateTimeStepsDeleter(time_steps_since_update=tentative_sets),
        data_associator=GNNWith2DAssignment(hypothesiser), updater=updater, measurement_model=None,
        min_points=config.min_points)
    return predictor, updater, hypothesiser, deleter, initiator


def gnn_tracker(config: PeerConfig) -> MultiTargetTracker:
    """Global nearest neighbour: 2-D assignment on Mahalanobis distances, EKF updates."""
    _, updater, hypothesiser, deleter, initiator = _parts(config)
    return MultiTargetTracker(initiator=initiator, deleter=deleter, detector=None,
                              data_associator=GNNWith2DAssignment(hypothesiser), updater=updater)


def clutter_density(config: PeerConfig) -> float:
    """False detections per unit of (azimuth rad x horizontal range m), see the module docstring."""
    radius = math.sqrt(max(config.max_range_m**2 - config.sensor_height_m**2, 1.0))
    return config.clutter_rate / (2.0 * math.pi * radius)


def jpda_tracker(config: PeerConfig) -> MultiTargetMixtureTracker:
    """Joint probabilistic data association: PDA hypotheses, joint events, moment-matched EKF updates."""
    predictor, updater, _, deleter, initiator = _parts(config)
    hypothesiser = PDAHypothesiser(predictor, updater, clutter_spatial_density=clutter_density(config),
                                   prob_detect=config.pd, prob_gate=config.prob_gate)
    return MultiTargetMixtureTracker(initiator=initiator, deleter=deleter, detector=None,
                                     data_associator=JPDA(hypothesiser), updater=updater)


def run_peer(tracker: MultiTargetTracker | MultiTargetMixtureTracker, scans: Iterable[Scan]) -> PeerRun:
    """Feed the scans in time order, each vehicle's detections as its own set at the scan's time.

    Returns the confirmed tracks after each scan and the time the scan took
    (``time.perf_counter``, seconds; measured here, never asserted by tests).
    """
    stamps, tracks, seconds = [], [], []
    for stamp_ns, per_vehicle, sensor, *_ in scans:  # (a fourth item, our trackers' coverage, is not theirs)
        when = _EPOCH + datetime.timedelta(microseconds=stamp_ns / 1000.0)
        start = time.perf_counter()
        for vehicle in sorted(per_vehicle):
            tracker.update_tracker(when, _stone_soup_detections(per_vehicle[vehicle], sensor, when))
        seconds.append(time.perf_counter() - start)
        stamps.append(int(stamp_ns))
        tracks.append(sorted((str(t.id), float(t.state_vector[0, 0]), float(t.state_vector[2, 0]))
                             for t in tracker.tracks))
    return PeerRun(tuple(stamps), tuple(tracks), tuple(seconds))
