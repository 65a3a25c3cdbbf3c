"""The zuo2021 section 5 experiments in one process: bearing-only tracking with distance-dependent noise.

Scenario (the paper's, from Dogancay 2012): the target starts at (10000, 3000) m;
UAVs start at (1000, 1000), (2000, 0), (1000, -1000) m (for 4-6 sensors, Fig. 7,
also (2000, 2000), (2000, -2000), (0, 0) m: our choice, the paper does not say),
fly at 40 m/s, turn at most 4 deg per 1 s step (eq. 36), must stay within 20 km of
the target (eq. 37) and 200-7500 m from each other (eq. 38-39). Every UAV measures
the target's bearing with the distance-dependent noise of eq. (2): ``sigma_0`` = 1
deg at ``r_0`` = 1500 m (about 6 deg at the initial 9 km). Choices the paper leaves
open (documented in ``docs/benchmarks.md``): the target drives at the constant
velocity (-4, 3) m/s, with no process noise; the UAVs start pointing at the
target's initial position; 100 steps; the filters use the ``cv2d`` model with
q = 0.01 m^2/s^3 and a zero-mean velocity prior of 5 m/s per axis.

The measurements come from the simulator's sensor
(:class:`sim_vehicles.truth.sensor.TargetSensor`, azimuth only, eq. (2) at the true
range), never from the filters' model.

* :func:`run_estimators` (Fig. 2): the UAVs fly straight at the target's initial
  position; ML-VUKF, ML-EKF and LS-EKF see the same bearings; the GCRLB of the
  tracking problem (:func:`gcs.core.gcrlb.tracking_gcrlb`) is the bound.
* the closed loop (Figs. 3-8) is :mod:`benchmarks.aoa_loop`, through the ground station's engine;
  :func:`path_violations` checks the constraints of eq. (36)-(39) on its flown paths with this
  module's own formulas, not the planner's.

Squared errors are of the position; "MSE" is their mean over runs at each step
(the paper's figures), and the runs of every configuration share seeds: the same
measurement noise draws.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.aoa_ekf import BearingEKF
from gcs.core.filters.aoa_init import ml_initialise, pseudo_linear_initialise
from gcs.core.filters.uif import NS_PER_S, GaussianEstimate
from gcs.core.filters.vgukf import ScanFilter, VariableGainUKF
from gcs.core.gcrlb import tracking_gcrlb
from gcs.core.geometry import wrap_angle
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from sim_vehicles.truth.sensor import TargetSensor

__all__ = ["AoaScenario", "LoopRecord", "PLANNERS", "ESTIMATORS", "run_estimators", "bound", "path_violations"]

PLANNERS = ("gcrlb_lm", "crlb_lm", "straight_line")
"""The planners of Figs. 3-6: the paper's, Dogancay's CRLB planner, straight flight at the target."""

ESTIMATORS = ("ml_vukf", "ml_ekf", "ls_ekf")
"""The estimators of Fig. 2: ML + VG-UKF (the paper's), ML + constant-noise EKF, LS + constant-noise EKF."""


@dataclass(frozen=True)
class AoaScenario:
    """The paper's section 5 set-up and the choices it leaves open (module docstring)."""

    target_start_m: tuple[float, float] = (10_000.0, 3_000.0)
    target_velocity_mps: tuple[float, float] = (-4.0, 3.0)
    uav_starts_m: tuple[tuple[float, float], ...] = (
        (1000.0, 1000.0), (2000.0, 0.0), (1000.0, -1000.0), (2000.0, 2000.0), (2000.0, -2000.0), (0.0, 0.0))
    speed_mps: float = 40.0
    step_s: float = 1.0
    max_turn_deg: float = 4.0
    reference_range_m: float = 1500.0
    detection_range_m: float = 20_000.0
    separation_m: tuple[float, float] = (200.0, 7500.0)
    steps: int = 100
    accel_psd_m2_s3: float = 0.01
    velocity_std_mps: float = 5.0

    def truth(self) -> NDArray[np.float64]:
        """Target states ``[x, y, vx, vy]`` at steps 0..K-1, shape (K, 4): constant velocity."""
        t = self.step_s * np.arange(self.steps)[:, None]
        velocity = np.asarray(self.target_velocity_mps)
        return np.hstack([np.asarray(self.target_start_m) + t * velocity, np.broadcast_to(velocity, (self.steps, 2))])

    def starts(self, count: int) -> NDArray[np.float64]:
        """The first ``count`` UAV start positions, ENU (count, 3), altitude 0 (the paper is planar)."""
        if not 1 <= count <= len(self.uav_starts_m):
            raise ValueError(f"between 1 and {len(self.uav_starts_m)} UAVs, got {count}")
        return np.column_stack([np.asarray(self.uav_starts_m[:count]), np.zeros(count)])

    def sensors(self, sigma0_deg: Sequence[float]) -> tuple[tuple[SensorModel, ...], tuple[TargetSensor, ...]]:
        """Filter models and truth sensors of UAVs with these ``sigma_0`` (eq. 2), one each."""
        models = tuple(SensorModel.bearing_only(math.radians(s), distance_dependent=True,
                                                reference_range_m=self.reference_range_m) for s in sigma0_deg)
        truths = tuple(TargetSensor(("azimuth",), (math.radians(s),), self.detection_range_m, distance_dependent=True,
                                    reference_range_m=self.reference_range_m) for s in sigma0_deg)
        return models, truths


@dataclass(frozen=True)
class LoopRecord:
    """One closed-loop run, K steps, M UAVs."""

    planner: str
    seed: int
    squared_error: NDArray[np.float64]  # (K,) position error^2 of the VG-UKF, m^2
    bound: NDArray[np.float64]  # (K,) trace of the tracking GCRLB along the flown path, m^2
    vehicle_xy: NDArray[np.float64]  # (K, M, 2) positions at each measurement
    heading: NDArray[np.float64]  # (K, M) heading flown after step k (the initial heading, then the decisions)
    target_xy: NDArray[np.float64]  # (K, 2)
    solve_s: NDArray[np.float64]  # (K - 1,) planner wall-clock time, NaN without a clock
    iterations: NDArray[np.int_]  # (K - 1,)
    violations: dict[str, int]  # constraint instances violated on the flown path (path_violations)


def _scan(truths: Sequence[TargetSensor], target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64],
          rng: np.random.Generator) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Bearings (M,) of the target from every UAV and which were detected (within range)."""
    target = np.array([target_xy[0], target_xy[1], 0.0])
    z, seen = np.full(len(truths), np.nan), np.zeros(len(truths), dtype=bool)
    for i, sensor in enumerate(truths):
        obs = sensor.observe(target, vehicle_xyz[i:i + 1], None, rng)
        z[i], seen[i] = obs.values[0, 0], obs.detected[0]
    return z, seen


def _fuse(flt: ScanFilter, estimate: GaussianEstimate, sensors: Sequence[SensorModel], z: NDArray[np.float64],
          seen: NDArray[np.bool_], vehicle_xyz: NDArray[np.float64]) -> GaussianEstimate:
    """Update with the detected UAVs' bearings (all of them in this scenario)."""
    if not seen.any():
        return estimate
    return flt.update(estimate, [s for s, ok in zip(sensors, seen) if ok], z[seen], vehicle_xyz[seen])


def bound(scenario: AoaScenario, sensors: Sequence[SensorModel], vehicle_xyz: NDArray[np.float64],
           truth: NDArray[np.float64]) -> NDArray[np.float64]:
    """Trace of the position block of the tracking GCRLB (no process noise, as the truth), shape (K,)."""
    prior = np.diag([0.0, 0.0, scenario.velocity_std_mps**-2, scenario.velocity_std_mps**-2])
    bound = tracking_gcrlb(constant_velocity(0.0), scenario.step_s, prior, sensors, vehicle_xyz, truth)
    return np.trace(bound[:, :2, :2], axis1=1, axis2=2)


def _squared_error(estimate: GaussianEstimate, truth: NDArray[np.float64]) -> float:
    d = estimate.mean[:2] - truth[:2]
    return float(d @ d)


def run_estimators(scenario: AoaScenario, seed: int) -> dict[str, NDArray[np.float64]]:
    """Fig. 2: squared errors (K,) of each of :data:`ESTIMATORS` and the bound ``gcrlb`` (K,) on one run.

    Three UAVs with ``sigma_0`` = 1 deg fly straight at the target's initial position.
    """
    truth = scenario.truth()
    starts = scenario.starts(3)
    aim = np.asarray(scenario.target_start_m) - starts[:, :2]
    direction = aim / np.linalg.norm(aim, axis=1, keepdims=True)
    t = scenario.step_s * np.arange(scenario.steps)[:, None, None]
    vehicles = starts + scenario.speed_mps * t * np.concatenate([direction, np.zeros((3, 1))], axis=1)
    sensors, truths = scenario.sensors([1.0] * 3)
    motion = constant_velocity(scenario.accel_psd_m2_s3)
    ml = partial(ml_initialise, max_range_m=scenario.detection_range_m)
    filters = {"ml_vukf": (ml, VariableGainUKF(motion)), "ml_ekf": (ml, BearingEKF(motion)),
               "ls_ekf": (pseudo_linear_initialise, BearingEKF(motion))}
    rng = np.random.default_rng([seed, 2])
    scans = [_scan(truths, truth[k], vehicles[k], rng) for k in range(scenario.steps)]
    out = {"gcrlb": bound(scenario, sensors, vehicles, truth)}
    for name, (initialise, flt) in filters.items():
        errors = np.zeros(scenario.steps)
        z, seen = scans[0]
        estimate = initialise(sensors, z, vehicles[0], 0, scenario.velocity_std_mps)
        errors[0] = _squared_error(estimate, truth[0])
        for k in range(1, scenario.steps):
            z, seen = scans[k]
            estimate = _fuse(flt, flt.predict(estimate, k * NS_PER_S), sensors, z, seen, vehicles[k])
            errors[k] = _squared_error(estimate, truth[k])
        out[name] = errors
    return out


def path_violations(scenario: AoaScenario, vehicle_xy: NDArray[np.float64], heading: NDArray[np.float64],
                    initial_heading: NDArray[np.float64], target_xy: NDArray[np.float64]) -> dict[str, int]:
    """Constraint instances (36)-(39) violated on a flown path, steps 1..K-1 (step 0 is the given start).

    ``heading`` (K, M) is flown after each step; ``initial_heading`` (M,) before step 0.
    """
    limit = math.radians(scenario.max_turn_deg) * (1.0 + 1e-9)
    flown = np.vstack([initial_heading, heading[:-1]])  # headings that led to steps 0..K-1 (eq. 35)
    turns = np.abs(wrap_angle(np.diff(flown, axis=0)))
    moved = vehicle_xy[1:]
    to_target = np.linalg.norm(moved - target_xy[1:, None, :], axis=-1)
    i, j = np.triu_indices(vehicle_xy.shape[1], k=1)
    apart = np.linalg.norm(moved[:, i] - moved[:, j], axis=-1)
    low, high = scenario.separation_m
    return {"turn": int((turns > limit).sum()), "detection": int((to_target > scenario.detection_range_m).sum()),
            "too_close": int((apart < low).sum()), "too_far": int((apart > high).sum())}
