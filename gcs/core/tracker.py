"""One decision step of the tracking loop (wang2012's ASRTP algorithm, section 4.3), pure.

``step(config, state, inputs, rng, now)`` -> ``(new_state, turn_rates, diagnostics)``:

1. fuse this step's detections into the target estimate with the DUIF
   (eq. 14-15; Step 2 of ASRTP), initialising the track from the first
   range-bearing detection when there is none yet; with a road graph, the road
   tracker instead (:class:`gcs.core.roads.RoadTracking`: particles on the roads,
   the looks of the vehicles that detected nothing as negative information);
2. predict the target k+1..k+n (eq. 16-17; Step 3; the road tracker's prediction
   branches at junctions and carries weighted samples), or hold the current
   estimate for the paper's "k+0" comparison;
3. build the planning problem with the visibility regions of the predicted
   points and solve it (Step 4); every plan then passes the airspace guard
   (:mod:`gcs.core.planners.airspace_guard`), which replaces a vehicle's plan
   that would enter restricted airspace;
4. return the first command of the plan for every vehicle (Step 5), and the
   plan itself to warm-start the next step.

The daemon, ``gcs replay --process`` and the benchmarks' closed loops (``gcs-bench``) drive
the engine (:mod:`gcs.engine`), which calls this function's halves apart: :func:`fuse` on every
decision step as it is released, :func:`plan` on the newest fused step when the
planner is free (docs/design.md, the layers); :func:`step` is the two in one, for
callers that plan every step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from gcs.core.detections import Detection, Sensing, initial_estimate, stack_detections
from gcs.core.filters.aoa_init import ml_initialise
from gcs.core.filters.imm_target import ImmEstimate, ImmTargetFilter
from gcs.core.filters.iterated import iterated_update
from gcs.core.filters.prediction import HorizonPrediction, predict_horizon
from gcs.core.filters.uif import NS_PER_S, GaussianEstimate, UnscentedInformationFilter
from gcs.core.filters.vgukf import VariableGainUKF
from gcs.core.kinematics import VehicleState
from gcs.core.models.sensor import RANGE, DetectionGroup, SensorModel
from gcs.core.planners.airspace_guard import AirspaceGuard
from gcs.core.planners.problem import Planner, PlanningProblem, PlanResult, RhcWeights, Visibility
from gcs.core.roads.outputs import RoadHorizon
from gcs.core.roads.particle import RoadParticleEstimate
from gcs.core.roads.tracking import RoadTracking
from gcs.core.world.sight_table import SightTable

__all__ = ["Detection", "Sensing", "TrackerConfig", "TrackerState", "StepInputs", "StepDiagnostics", "fuse",
           "iterated_update", "prediction", "plan", "step", "initial_estimate"]


@dataclass(frozen=True)
class StepInputs:
    """What one decision step sees: the time, the vehicles now, this step's detections, and who sensed."""

    stamp_ns: int
    vehicles: VehicleState
    detections: Sequence[Detection] = ()
    sensing: Sensing | None = None


@dataclass(frozen=True)
class TrackerConfig:
    """Parameters of the loop; holds no estimate.

    ``visibility`` builds the visibility regions of the predicted target
    points (T, 2) (None: open field); ``restricted`` tests restricted airspace.
    ``predict_ahead = False`` plans on the current estimate (the paper's k+0).
    """

    uif: UnscentedInformationFilter
    sensors: tuple[SensorModel, ...]
    planner: Planner
    max_turn_rate: NDArray[np.float64]
    step_s: float = 1.0
    horizon_steps: int = 5
    weights: RhcWeights = RhcWeights()
    predict_ahead: bool = True
    visibility: Callable[[NDArray[np.float64]], Visibility] | None = None
    restricted: Callable[[NDArray[np.float64]], NDArray[np.bool_]] | None = None
    initial_position_std_m: float = 50.0
    initial_velocity_std_mps: float = 10.0
    bearing_filter: VariableGainUKF | None = None
    """zuo2021's VG-UKF: set for bearing-only sensors, replacing the DUIF in :func:`fuse`."""
    target_imm: ImmTargetFilter | None = None
    """The CV + coordinated-turn IMM: set to replace the single-model DUIF in :func:`fuse`."""
    sight: SightTable | None = None
    """Where ground points can be seen from, for the sight planner."""
    guard: AirspaceGuard = AirspaceGuard()
    """Restricted airspace as a hard constraint on every planner's plan."""
    max_range_m: float = float("inf")
    """The sensors' range, metres."""
    road: RoadTracking | None = None
    """The road tracker: set (a world with a road graph) to replace the DUIF in :func:`fuse` and the
    constant-velocity prediction in :func:`prediction`."""


@dataclass(frozen=True)
class TrackerState:
    """The loop's memory: the target estimate, the last plan (V, T) and the commands being flown."""

    estimate: GaussianEstimate | None
    plan: NDArray[np.float64] | None
    turn_rate: NDArray[np.float64]

    @classmethod
    def start(cls, vehicles: int) -> TrackerState:
        """No track yet, every vehicle flying straight."""
        return cls(None, None, np.zeros(vehicles))


@dataclass(frozen=True)
class StepDiagnostics:
    """What happened in a step, for status, plots and benchmarks."""

    estimate: GaussianEstimate | None
    prediction: HorizonPrediction | None
    plan: PlanResult | None
    detections: int
    extras: dict[str, object] = field(default_factory=dict)


def fuse(config: TrackerConfig, estimate: GaussianEstimate | None, stamp_ns: int,
         detections: Sequence[Detection], sensing: Sensing | None = None) -> GaussianEstimate | None:
    """Step 2 of ASRTP alone: the DUIF update of the estimate with one step's detections (eq. 14-15).

    The track starts from the first range-bearing detection (bearing-only sensors:
    zuo2021's ML initialisation and VG-UKF, when ``config.bearing_filter`` is set). With
    ``config.target_imm`` the CV + coordinated-turn IMM replaces the single model, each of its
    modes updated by the DUIF (:mod:`gcs.core.filters.imm_target`). With ``config.road`` the
    road tracker replaces both (:func:`_fuse_road`), and ``sensing`` (every vehicle that
    sensed at the step) gives it the looks that found nothing. Detections index
    ``config.sensors`` by their ``vehicle``. Deterministic: the same estimate and
    detections give the same result bit for bit (the daemon and ``gcs replay
    --process`` rely on it). None while nothing has been seen.
    """
    if config.road is not None:
        return _fuse_road(config, config.road, estimate, stamp_ns, detections, sensing)
    if config.bearing_filter is not None:
        return _fuse_bearings(config, config.bearing_filter, estimate, stamp_ns, detections)
    if estimate is None:
        if not detections:
            return None
        first = detections[0]
        estimate = initial_estimate(first, config.sensors[first.vehicle], stamp_ns,
                                    config.initial_position_std_m, config.initial_velocity_std_mps,
                                    config.uif.motion.dim)
    stacked = stack_detections(config.sensors, detections)
    if config.target_imm is not None:
        if not isinstance(estimate, ImmEstimate):
            estimate = config.target_imm.start(estimate)
        return config.target_imm.step(estimate, stamp_ns, stacked)
    prior = config.uif.predict(estimate, stamp_ns)
    return iterated_update(config.uif, prior, stacked)


def _fuse_road(config: TrackerConfig, road: RoadTracking, estimate: GaussianEstimate | None, stamp_ns: int,
               detections: Sequence[Detection], sensing: Sensing | None) -> GaussianEstimate | None:
    """The road tracker's step (:class:`~gcs.core.roads.RoadTracking`): every detection, fused as the DUIF fuses
    them, and the looks of ``sensing``. A track starts from the first detection with a range (inverted,
    :func:`initial_estimate`), or from zuo2021's ML fix of two bearings or more."""
    stacked = stack_detections(config.sensors, detections)
    looks = None if sensing is None else road.looks(sensing.vehicle_xyz, sensing.detected)
    if isinstance(estimate, RoadParticleEstimate):
        return road.step(estimate, stamp_ns, stacked, looks)
    if estimate is not None:  # a Gaussian track handed over: its prediction starts the particles
        return road.start(config.uif.predict(estimate, stamp_ns), stacked, looks)
    ranged = [d for d in detections if RANGE in config.sensors[d.vehicle].components]
    if ranged:
        start = initial_estimate(ranged[0], config.sensors[ranged[0].vehicle], stamp_ns,
                                 config.initial_position_std_m, config.initial_velocity_std_mps, 4)
    else:
        bearings_fix = _bearings_fix(config, stamp_ns, detections)
        if bearings_fix is None:
            return None
        start = bearings_fix
    return road.start(start, stacked, looks)


def _fuse_bearings(config: TrackerConfig, bearing_filter: VariableGainUKF, estimate: GaussianEstimate | None,
                   stamp_ns: int, detections: Sequence[Detection]) -> GaussianEstimate | None:
    """zuo2021's estimator for bearing-only sensors: ML initialisation from the first scan of at
    least two bearings (section 2.3 (1)), then the variable-gain UKF (eq. 5-14) on every scan."""
    if estimate is None:
        return _bearings_fix(config, stamp_ns, detections)
    prior = bearing_filter.predict(estimate, stamp_ns)
    if not detections:
        return prior
    return bearing_filter.update(prior, [config.sensors[d.vehicle] for d in detections],
                                 [d.values for d in detections], np.stack([d.vehicle_xyz for d in detections]))


def _bearings_fix(config: TrackerConfig, stamp_ns: int, detections: Sequence[Detection]) -> GaussianEstimate | None:
    """zuo2021's ML fix (section 2.3 (1)) of a scan of at least two detections; None with fewer."""
    if len(detections) < 2:
        return None
    return ml_initialise([config.sensors[d.vehicle] for d in detections], [d.values for d in detections],
                         np.stack([d.vehicle_xyz for d in detections]), stamp_ns, config.initial_velocity_std_mps)


def prediction(config: TrackerConfig, estimate: GaussianEstimate) -> HorizonPrediction:
    """Step 3: the k+1..k+n predictions (eq. 16-17), or the estimate held (the paper's k+0).

    A road track's prediction is the road tracker's (:meth:`~gcs.core.roads.RoadTracking.horizon`): a
    :class:`~gcs.core.roads.RoadHorizon`, the moment-matched Gaussians and the weighted samples of every
    branch. Held (k+0), a road track is its moment-matched Gaussian."""
    if config.predict_ahead and config.road is not None and isinstance(estimate, RoadParticleEstimate):
        return config.road.horizon(estimate, config.step_s, config.horizon_steps)
    if config.predict_ahead:
        return predict_horizon(config.uif, estimate, config.step_s, config.horizon_steps)
    step_ns = int(round(config.step_s * NS_PER_S))
    stamps = tuple(estimate.stamp_ns + (j + 1) * step_ns for j in range(config.horizon_steps))
    held = GaussianEstimate(np.tile(estimate.mean, (config.horizon_steps, 1)),
                            np.tile(estimate.cov, (config.horizon_steps, 1, 1)), stamps[0])
    return HorizonPrediction(stamps, held)


def plan(
    config: TrackerConfig,
    state: TrackerState,
    vehicles: VehicleState,
    rng: np.random.Generator,
    now: Callable[[], float] | None = None,
    predicted: HorizonPrediction | None = None,
) -> tuple[TrackerState, NDArray[np.float64], StepDiagnostics]:
    """Steps 3-5 of ASRTP for the state's (already fused) estimate: predict, plan, first commands (V,).

    ``config`` describes the V vehicles of ``vehicles`` (its sensors and turn
    limits), which may be a subset of the roster the estimate was fused with.
    ``predicted`` is :func:`prediction` of the estimate when the caller has it already.
    """
    estimate = state.estimate
    if estimate is None:  # nothing seen yet: hold course
        return state, state.turn_rate, StepDiagnostics(None, None, None, 0)
    if predicted is None:
        predicted = prediction(config, estimate)
    problem = PlanningProblem(
        vehicles=vehicles,
        current_turn_rate=state.turn_rate,
        max_turn_rate=config.max_turn_rate,
        step_s=config.step_s,
        target_means=predicted.states.mean,
        target_covs=predicted.states.cov,
        target_samples=predicted.samples if isinstance(predicted, RoadHorizon) else None,
        target_sample_weights=predicted.weights if isinstance(predicted, RoadHorizon) else None,
        sensors=config.sensors,
        visibility=None if config.visibility is None else config.visibility(predicted.positions),
        restricted=config.restricted,
        weights=config.weights,
        sight=config.sight,
        guard=config.guard,
        max_range_m=config.max_range_m,
    )
    result = config.planner.solve(problem, rng, warm_start=state.plan, now=now)
    safe = config.guard.safe(vehicles, result.controls, config.step_s, config.max_turn_rate)
    if safe is not result.controls:
        result = replace(result, controls=safe, message=f"{result.message}; airspace fallback")
    turn_rate = result.controls[:, 0].copy()
    return TrackerState(estimate, result.controls, turn_rate), turn_rate, StepDiagnostics(estimate, predicted, result, 0)


def step(
    config: TrackerConfig,
    state: TrackerState,
    inputs: StepInputs,
    rng: np.random.Generator,
    now: Callable[[], float] | None = None,
) -> tuple[TrackerState, NDArray[np.float64], StepDiagnostics]:
    """One ASRTP step (:func:`fuse` then :func:`plan`); see the module docstring.

    Returns the new state, the turn rates (V,) to fly now and the diagnostics.
    """
    estimate = fuse(config, state.estimate, inputs.stamp_ns, inputs.detections, inputs.sensing)
    new_state, turn_rate, diagnostics = plan(config, replace(state, estimate=estimate), inputs.vehicles, rng, now)
    return new_state, turn_rate, replace(diagnostics, detections=len(inputs.detections))
