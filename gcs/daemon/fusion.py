"""One decision step into wire messages: shared by the daemon and ``gcs replay --process``.

Both call :func:`fuse_step` on the same steps and get the same ``TrackEstimate``
bit for bit: detections are taken in roster order (not arrival order) from
every roster vehicle that reported in the step, whether or not it is being
planned for, and the prediction is the tracker's own (eq. 16-17).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.filters.uif import GaussianEstimate
from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout
from gcs.core.tracker import Detection, TrackerConfig, TrackerState, fuse, prediction
from gcs.daemon.steps import ReadyStep
from gcs.config import VehicleConfig
from protocols.messages import PlanCommand, PredictedPoint, SensorReport, TrackEstimate

__all__ = ["step_detections", "fuse_step", "track_message", "plan_commands", "PlanMemory"]


def _measurement(report: SensorReport, components: tuple[str, ...]) -> np.ndarray | None:
    """The report's values in the sensor model's component order; None if one is missing."""
    fields = {"range": report.range_m, "azimuth": report.azimuth_rad, "elevation": report.elevation_rad}
    values = [fields[c] for c in components]
    return None if any(v is None for v in values) else np.array(values, dtype=np.float64)


def step_detections(ready: ReadyStep, roster: Sequence[str], config: TrackerConfig) -> tuple[Detection, ...]:
    """The step's detections in roster order (a vehicle's first report of the step counts)."""
    first: dict[str, SensorReport] = {}
    for report in ready.reports:
        first.setdefault(report.vehicle_id, report)
    detections = []
    for index, vehicle_id in enumerate(roster):
        report = first.get(vehicle_id)
        if report is None or not report.detected:
            continue
        values = _measurement(report, config.sensors[index].components)
        if values is not None:
            detections.append(Detection(index, np.asarray(report.vehicle_position_enu_m, dtype=np.float64), values))
    return tuple(detections)


def _symmetric(matrix: np.ndarray) -> np.ndarray:
    """Exactly symmetric copy (the wire checks symmetry)."""
    return 0.5 * (matrix + matrix.T)


def track_message(config: TrackerConfig, estimate: GaussianEstimate, target_id: str, model: str, seq: int,
                  contributing: Sequence[str], predicted: HorizonPrediction | None = None) -> TrackEstimate:
    """The wire message of an estimate, with the k+1..k+n prediction (computed unless given)."""
    if predicted is None:
        predicted = prediction(config, estimate)
    points = tuple(
        PredictedPoint(stamp_ns=int(stamp), position_enu_m=(float(mean[0]), float(mean[1])),
                       position_cov_m2=tuple(float(c) for c in _symmetric(cov[:2, :2]).ravel()))
        for stamp, mean, cov in zip(predicted.stamps_ns, predicted.states.mean, predicted.states.cov))
    return TrackEstimate(target_id=target_id, seq=seq, stamp_ns=estimate.stamp_ns, model=model,
                         state=tuple(float(v) for v in estimate.mean),
                         covariance=tuple(float(c) for c in _symmetric(estimate.cov).ravel()),
                         contributing_vehicles=tuple(contributing), prediction=points)


def fuse_step(config: TrackerConfig, estimate: GaussianEstimate | None, ready: ReadyStep, roster: Sequence[str]
              ) -> tuple[GaussianEstimate | None, tuple[Detection, ...]]:
    """The estimate after one step, and the detections that went into it."""
    detections = step_detections(ready, roster, config)
    return fuse(config, estimate, ready.stamp_ns, detections), detections


def plan_commands(vehicles: VehicleState, configs: Sequence[VehicleConfig], controls: np.ndarray,
                  max_turn_rate: np.ndarray, step_s: float, stamp_ns: int, first_seq: int, planner: str
                  ) -> list[PlanCommand]:
    """One ``PlanCommand`` per planned vehicle: the heading at the end of the step
    (``psi + u T``), the first turn rate and the planned path over the horizon."""
    path, _ = rollout(vehicles, controls, step_s, max_turn_rate)
    commands = []
    for slot, cfg in enumerate(configs):
        turn_rate = float(controls[slot, 0])
        commands.append(PlanCommand(
            vehicle_id=cfg.id, seq=first_seq + slot, stamp_ns=stamp_ns,
            heading_rad=wrap_angle(float(vehicles.heading[slot] + turn_rate * step_s)), turn_rate_rad_s=turn_rate,
            airspeed_mps=cfg.speed_mps, altitude_m=cfg.altitude_m,
            planned_path_enu_m=tuple((float(x), float(y)) for x, y in path[slot]), planner=planner))
    return commands


@dataclass
class PlanMemory:
    """Each vehicle's last planned row (the GA's warm start) and the turn rate it is flying,
    kept by vehicle id so that a planning subset can change from step to step."""

    rows: dict[str, np.ndarray] = field(default_factory=dict)
    turn_rate: dict[str, float] = field(default_factory=dict)

    def state_for(self, active: Sequence[str], estimate: GaussianEstimate) -> TrackerState:
        """The tracker state for the vehicles planned now (a warm start only if every one has a row)."""
        rows = [self.rows.get(v) for v in active]
        warm = np.stack(rows) if all(r is not None for r in rows) else None
        return TrackerState(estimate, warm, np.array([self.turn_rate.get(v, 0.0) for v in active]))

    def remember(self, active: Sequence[str], state: TrackerState, turn_rates: np.ndarray) -> None:
        """Keep the new plan's rows and commands."""
        for slot, vehicle_id in enumerate(active):
            if state.plan is not None:
                self.rows[vehicle_id] = state.plan[slot]
            self.turn_rate[vehicle_id] = float(turn_rates[slot])
