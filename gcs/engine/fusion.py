"""One decision step's reports into the trackers' detections, and the trackers' results into wire messages.

The engine fuses every released step with :func:`fuse_step` (one target) or a scan of
the multi-target tracker (:func:`scan_detections`), so that the daemon and ``gcs replay
--process`` get the same ``TrackEstimate`` bit for bit: detections are taken in roster
order (not arrival order) from every roster vehicle that reported in the step, whether
or not it is being planned for, and the prediction is the tracker's own (eq. 16-17).
With a :class:`~gcs.engine.navigation.FleetNavigator` (advanced to the step's stamp by
the caller) a detection's vehicle position and its covariance are the navigator's;
without one, or for a vehicle it has no estimate of, the report's own
``vehicle_position_enu_m``, uncertain by its ``vehicle_position_std_m``.

The single-target tracker (:class:`~gcs.core.single_target.SingleTargetTracker`) takes
at most one detection from each report, the one nearest the track
(:func:`~gcs.core.single_target.choose_detections`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.filters.uif import GaussianEstimate, NotPositiveDefinite
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout
from gcs.core.models.sensor import SensorModel
from gcs.core.single_target import SingleTargetTracker, choose_detections
from gcs.core.tracker import Detection, Sensing, TrackerConfig, TrackerState, prediction
from gcs.engine.navigation import FleetNavigator
from gcs.engine.steps import ReadyStep
from gcs.config import VehicleConfig
from protocols.messages import PlanCommand, PredictedPoint, SensorReport, TrackEstimate

__all__ = ["reported_detections", "step_detections", "scan_detections", "step_sensing", "fuse_step", "FusionDiverged",
           "check_estimate", "track_message", "plan_commands", "PlanMemory", "with_observers"]


_REPORT_FIELD = {"range": "range_m", "azimuth": "azimuth_rad", "elevation": "elevation_rad"}
"""The ``SensorReport`` field of each sensor model component."""


def _measurements(report: SensorReport, components: tuple[str, ...]) -> list[NDArray[np.float64]]:
    """The report's detections that have every component of the sensor model, as value vectors
    in the model's component order (report order kept)."""
    fields = [_REPORT_FIELD[c] for c in components]
    out = []
    for detection in report.detections:
        values = [getattr(detection, name) for name in fields]
        if None not in values:
            out.append(np.array(values, dtype=np.float64))
    return out


def _first_reports(ready: ReadyStep) -> dict[str, SensorReport]:
    """Each vehicle's first report of the step (the one fused), by vehicle id."""
    first: dict[str, SensorReport] = {}
    for report in ready.reports:
        first.setdefault(report.vehicle_id, report)
    return first


def _reported_cov(report: SensorReport) -> float | None:
    """The per-axis variance ``std^2`` of the report's ``vehicle_position_std_m``; None without one (or 0)."""
    std = report.vehicle_position_std_m
    return std * std if std else None


def reported_detections(ready: ReadyStep, roster: Sequence[str], sensors: Sequence[SensorModel],
                        navigator: FleetNavigator | None = None) -> dict[int, list[Detection]]:
    """Every detection of the step by roster index, of the vehicles whose report has one (a vehicle's first
    report of the step counts; a detection without every component of its vehicle's sensor model is left out).

    With a ``navigator`` the vehicle's position is its estimate at the report's stamp, horizontal
    from the SKF and vertical from the report, with the (3, 3) covariance of
    :meth:`FleetNavigator.position_at` as ``Detection.vehicle_cov``. Without one it is the
    report's own position, uncertain by the report's ``vehicle_position_std_m`` on every axis
    when given: a few metres of GPS error are nothing 300 m from the target, but from
    right above it they turn the azimuth around, and the filter must know.
    """
    first = _first_reports(ready)
    detections: dict[int, list[Detection]] = {}
    for index, vehicle_id in enumerate(roster):
        report = first.get(vehicle_id)
        if report is None or not report.detected:
            continue
        candidates = _measurements(report, sensors[index].components)
        if candidates:
            where, cov = _vehicle_position(report, navigator)
            detections[index] = [Detection(index, where, values, vehicle_cov=cov) for values in candidates]
    return detections


def step_detections(ready: ReadyStep, roster: Sequence[str], config: TrackerConfig,
                    navigator: FleetNavigator | None = None,
                    estimate: GaussianEstimate | None = None) -> tuple[Detection, ...]:
    """The step's detections the single-target tracker fuses, in roster order: of each vehicle's
    (:func:`reported_detections`), the one :func:`gcs.core.single_target.choose_detections` picks against
    ``estimate`` (the track before this step)."""
    return choose_detections(config, estimate, ready.stamp_ns, reported_detections(ready, roster, config.sensors,
                                                                                   navigator))


def with_observers(config: TrackerConfig, roster: Sequence[str], observers: Sequence[str], sensor: SensorModel
                   ) -> tuple[list[str], TrackerConfig]:
    """The roster and tracker that fuse ``observers`` (vehicles outside the roster, accepted on request)
    after the roster's own vehicles, each with ``sensor``; planning keeps the roster's tracker."""
    if not observers:
        return list(roster), config
    return [*roster, *observers], replace(config, sensors=config.sensors + (sensor,) * len(observers))


def _symmetric(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """Exactly symmetric copy (the wire checks symmetry)."""
    symmetric: NDArray[np.float64] = 0.5 * (matrix + matrix.T)
    return symmetric


def track_message(config: TrackerConfig, estimate: GaussianEstimate, target_id: str, model: str, seq: int,
                  contributing: Sequence[str], predicted: HorizonPrediction | None = None) -> TrackEstimate:
    """The wire message of an estimate, with the k+1..k+n prediction (computed unless given)."""
    if predicted is None:
        predicted = prediction(config, estimate)
    covs = predicted.states.cov[:, :2, :2]
    points = tuple(
        PredictedPoint(stamp_ns=stamp, position_enu_m=tuple(mean), position_cov_m2=tuple(cov))
        for stamp, mean, cov in zip(np.asarray(predicted.stamps_ns).tolist(), predicted.states.mean[:, :2].tolist(),
                                    (0.5 * (covs + covs.swapaxes(-1, -2))).reshape(-1, 4).tolist()))
    return TrackEstimate(target_id=target_id, seq=seq, stamp_ns=estimate.stamp_ns, model=model,
                         state=tuple(estimate.mean.tolist()), covariance=tuple(_symmetric(estimate.cov).ravel().tolist()),
                         contributing_vehicles=tuple(contributing), prediction=points)


class FusionDiverged(ValueError):
    """A step's detections gave no usable estimate (non-finite, not positive definite, or a position
    standard deviation beyond :data:`MAX_POSITION_VARIANCE_M2`); the previous estimate stands."""


MAX_POSITION_VARIANCE_M2 = 1e12
"""A position variance beyond (1000 km)^2 is no estimate of a ground target: the step is rejected."""


def check_estimate(estimate: GaussianEstimate | None) -> None:
    """Raise :class:`FusionDiverged` unless the estimate is finite with a positive-definite covariance."""
    if estimate is None:
        return
    mean, cov = estimate.mean, estimate.cov
    if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
        raise FusionDiverged("the fused estimate is not finite")
    variances = (float(cov[0, 0]), float(cov[1, 1]))
    if not max(variances) <= MAX_POSITION_VARIANCE_M2:
        raise FusionDiverged(f"the fused position variance {variances} is beyond {MAX_POSITION_VARIANCE_M2:g}")
    try:
        np.linalg.cholesky(_symmetric(cov))
    except np.linalg.LinAlgError as error:
        raise FusionDiverged("the fused covariance is not positive definite") from error


def _vehicle_position(report: SensorReport, navigator: FleetNavigator | None
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64] | float | None]:
    """Where the vehicle was at the report's stamp (3,) and the covariance of that (see :func:`step_detections`)."""
    xyz = np.array(report.vehicle_position_enu_m, dtype=np.float64)
    navigated = None if navigator is None else navigator.position_at(report.vehicle_id, report.stamp_ns)
    if navigated is None:
        return xyz, _reported_cov(report)
    xy, cov = navigated
    return np.array([xy[0], xy[1], xyz[2]]), cov


def scan_detections(ready: ReadyStep, roster: Sequence[str], sensors: Sequence[SensorModel],
                    navigator: FleetNavigator | None = None) -> tuple[dict[int, list[Detection]], NDArray[np.float64]]:
    """Every detection of the step by roster index (a vehicle's first report of the step counts), for the
    multi-target tracker, and where each vehicle that reported was (R, 3), detections or not.

    Positions as in :func:`step_detections`; a detection without every component of its
    vehicle's sensor model is left out."""
    first = _first_reports(ready)
    detections: dict[int, list[Detection]] = {}
    positions = []
    for index, vehicle_id in enumerate(roster):
        report = first.get(vehicle_id)
        if report is None:
            continue
        where, cov = _vehicle_position(report, navigator)
        positions.append(where)
        found = [Detection(index, where, values, vehicle_cov=cov)
                 for values in _measurements(report, sensors[index].components)]
        if found:
            detections[index] = found
    return detections, np.array(positions, dtype=np.float64).reshape(-1, 3)


def step_sensing(ready: ReadyStep, roster: Sequence[str], navigator: FleetNavigator | None = None) -> Sensing:
    """Every roster vehicle that reported in the step (its first report), in roster order: where it was (as in
    :func:`reported_detections`) and whether it detected anything; the road tracker's negative information."""
    first = _first_reports(ready)
    reported = [first[v] for v in roster if v in first]
    xyz = np.array([_vehicle_position(report, navigator)[0] for report in reported], dtype=np.float64)
    return Sensing(xyz.reshape(-1, 3), np.array([report.detected for report in reported], dtype=bool))


def fuse_step(config: TrackerConfig, estimate: GaussianEstimate | None, ready: ReadyStep, roster: Sequence[str],
              navigator: FleetNavigator | None = None) -> tuple[GaussianEstimate | None, tuple[Detection, ...]]:
    """The estimate after one step, and the detections that went into it: one scan of the single-target tracker
    (:class:`~gcs.core.single_target.SingleTargetTracker`) with the step's detections (:func:`reported_detections`)
    and, for the road tracker, who sensed (:func:`step_sensing`).

    Raises :class:`FusionDiverged` when the detections (valid on the wire, but absurd together or with
    the prior) give no usable estimate, so that one bad step cannot poison the track that follows.
    """
    tracker = SingleTargetTracker(config)
    detections = reported_detections(ready, roster, config.sensors, navigator)
    sensing = step_sensing(ready, roster, navigator) if config.road is not None else None
    try:
        fused, scanned = tracker.scan(estimate, ready.stamp_ns, detections, config.sensors, None, sensing)
    except (NotPositiveDefinite, np.linalg.LinAlgError, ArithmeticError) as error:
        raise FusionDiverged(f"fusing step {ready.index} failed: {error}") from error
    check_estimate(fused)
    return fused, scanned.detections


def plan_commands(vehicles: VehicleState, configs: Sequence[VehicleConfig], controls: NDArray[np.float64],
                  max_turn_rate: NDArray[np.float64], step_s: float, stamp_ns: int, first_seq: int, planner: str
                  ) -> list[PlanCommand]:
    """One ``PlanCommand`` per planned vehicle: the heading at the end of the step
    (``psi + u T``), the first turn rate and the planned path over the horizon."""
    path, _ = rollout(vehicles, controls, step_s, max_turn_rate, headings=False)
    paths = path.tolist()  # (V, n, 2) as Python floats
    turn_rates = np.asarray(controls[:, 0], dtype=np.float64)
    headings = wrap_angle(vehicles.heading + turn_rates * step_s).tolist()
    return [PlanCommand(vehicle_id=cfg.id, seq=first_seq + slot, stamp_ns=stamp_ns, heading_rad=heading,
                        turn_rate_rad_s=turn_rate, airspeed_mps=cfg.speed_mps, altitude_m=cfg.altitude_m,
                        planned_path_enu_m=tuple(map(tuple, path_)), planner=planner)
            for slot, (cfg, heading, turn_rate, path_) in enumerate(zip(configs, headings, turn_rates.tolist(), paths))]


@dataclass
class PlanMemory:
    """Each vehicle's last planned row (the GA's warm start) and the turn rate it is flying,
    kept by vehicle id so that a planning subset can change from step to step."""

    rows: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    turn_rate: dict[str, float] = field(default_factory=dict)

    def state_for(self, active: Sequence[str], estimate: GaussianEstimate | None) -> TrackerState:
        """The tracker state for the vehicles planned now (a warm start only if every one has a row)."""
        rows = [self.rows[v] for v in active if v in self.rows]
        warm = np.stack(rows) if len(rows) == len(active) else None
        return TrackerState(estimate, warm, np.array([self.turn_rate.get(v, 0.0) for v in active]))

    def remember(self, active: Sequence[str], state: TrackerState, turn_rates: NDArray[np.float64]) -> None:
        """Keep the new plan's rows and commands."""
        for slot, vehicle_id in enumerate(active):
            if state.plan is not None:
                self.rows[vehicle_id] = state.plan[slot]
            self.turn_rate[vehicle_id] = float(turn_rates[slot])
