"""zuo2021's closed loop (Figs. 3-8) through the ground station's engine: bearing-only UAVs planned by the GCRLB.

The set-up is :class:`benchmarks.aoa.AoaScenario`'s, as a scenario the engine runs (:func:`aoa_scenario`:
bearing-only sensors with eq. (2)'s noise, the ``vgukf`` estimator, the planner by its name, the UAVs'
speed and 4 deg-per-step turn limit), flown by :mod:`benchmarks.closed_loop`. Each 1 s step the UAVs
report the target's bearing (:class:`sim_vehicles.truth.sensor.TargetSensor`, eq. (2) at the true range,
every UAV's draw in order from ``[seed, 2]``, as the estimators' runs of :mod:`benchmarks.aoa`); the engine
initialises the track by ML from the first scan and runs the VG-UKF, predicts ``x_{k+1|k}`` and submits the
step's plan: the heading planner's one-step decision (eq. 34-39) as a turn rate, which the UAVs fly for
the step (an arc of eq. 1; the paper's eq. (35) turns first and flies straight). The constraints of
eq. (36)-(39) are checked on the flown path with :func:`benchmarks.aoa.path_violations`'s own formulas.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import msgspec
import numpy as np
from numpy.typing import NDArray

from benchmarks.aoa import AoaScenario, LoopRecord, bound, path_violations
from benchmarks.closed_loop import IN_PROCESS, NS_PER_S, EngineLoop, IdealAirframes, fly_step
from gcs.config import Scenario
from gcs.core.kinematics import VehicleState
from gcs.engine.plan_jobs import plan_job
from gcs.scenarios import load_scenario
from protocols.keys import nav_key, report_key, truth_key
from protocols.messages import NavReport, SensorReport, TargetTruth
from sim_vehicles.scene import wire_measurement

__all__ = ["ENGINE_PLANNERS", "aoa_scenario", "run_loop", "run_alternated"]

ENGINE_PLANNERS = {"gcrlb_lm": "gcrlb_lm", "crlb_lm": "crlb_lm", "straight_line": "straight"}
"""The planners of Figs. 3-6 (:data:`benchmarks.aoa.PLANNERS`) and the names the engine knows them by."""


def aoa_scenario(setup: AoaScenario, planner: str, sigma0_deg: Sequence[float]) -> Scenario:
    """The shipped ``zuo2021_aoa`` scenario with ``setup``'s UAVs (one per ``sigma_0``, each its own sensor),
    target, turn limit, filter and ``planner`` (a key of :data:`ENGINE_PLANNERS`), in the paper's frame."""
    base = load_scenario("zuo2021_aoa")
    starts = setup.starts(len(sigma0_deg))
    aim = np.asarray(setup.target_start_m) - starts[:, :2]
    vehicles = []
    for i, (start, sigma0) in enumerate(zip(starts, sigma0_deg)):
        sensor = msgspec.structs.replace(base.sensor, azimuth_std_rad=math.radians(sigma0),
                                         reference_range_m=setup.reference_range_m,
                                         max_range_m=setup.detection_range_m)
        vehicles.append(msgspec.structs.replace(
            base.vehicles[0], id=f"uav{i + 1}", sysid=i + 1, altitude_m=100.0 + 10.0 * i, speed_mps=setup.speed_mps,
            max_turn_rate_rad_s=math.radians(setup.max_turn_deg) / setup.step_s, start_enu_m=tuple(start[:2]),
            start_heading_rad=float(math.atan2(aim[i, 1], aim[i, 0])), sensor=sensor))
    return msgspec.structs.replace(
        base, vehicles=vehicles,
        time=msgspec.structs.replace(base.time, step_s=setup.step_s, duration_s=setup.steps * setup.step_s),
        target=msgspec.structs.replace(base.target, start_enu_m=setup.target_start_m,
                                       start_velocity_mps=setup.target_velocity_mps),
        estimator=msgspec.structs.replace(base.estimator, accel_psd_m2_s3=setup.accel_psd_m2_s3,
                                          initial_velocity_std_mps=setup.velocity_std_mps),
        planner=msgspec.structs.replace(base.planner, kind=ENGINE_PLANNERS[planner]))


class _AoaScene:
    """The target's constant-velocity truth, and each UAV's bearing of it at the start of every step."""

    def __init__(self, setup: AoaScenario, scenario: Scenario, seed: int) -> None:
        self.roster = [v.id for v in scenario.vehicles]
        self.truth = setup.truth()
        self.step_s = setup.step_s
        self.sensors = setup.sensors([math.degrees(scenario.sensor_for(v).azimuth_std_rad)
                                      for v in scenario.vehicles])[1]
        self.rng = np.random.default_rng([seed, 2])
        steps, count = setup.steps, len(self.roster)
        self.vehicle_xyz, self.heading = np.zeros((steps, count, 3)), np.zeros((steps, count))

    def messages(self, step: int, substep: int, vehicles: VehicleState | None) -> list[tuple[str, object]]:
        if substep != 0 or vehicles is None:
            return []
        stamp = round(step * self.step_s * NS_PER_S)
        self.vehicle_xyz[step], self.heading[step] = vehicles.xyz, vehicles.heading
        x, y, vx, vy = (float(v) for v in self.truth[step])
        out: list[tuple[str, object]] = []
        for i, (vehicle_id, sensor) in enumerate(zip(self.roster, self.sensors)):
            heading = float(vehicles.heading[i])
            velocity = (float(vehicles.speed[i] * math.cos(heading)), float(vehicles.speed[i] * math.sin(heading)), 0.0)
            out.append((nav_key(vehicle_id), NavReport(vehicle_id=vehicle_id, seq=step + 1, stamp_ns=stamp,
                                                       velocity_enu_mps=velocity, heading_rad=heading)))
        for i, (vehicle_id, sensor) in enumerate(zip(self.roster, self.sensors)):
            where = vehicles.xyz[i]
            observed = sensor.observe(np.array([x, y, 0.0]), where[None], None, self.rng)
            found = ()
            if observed.detected[0]:
                std = sensor.std_at(math.dist((x, y, 0.0), where))
                found = (wire_measurement(sensor.components, observed.values[0], std),)
            out.append((report_key(vehicle_id), SensorReport(vehicle_id=vehicle_id, seq=step + 1, stamp_ns=stamp,
                                                             vehicle_position_enu_m=tuple(map(float, where)),
                                                             detections=found)))
        out.append((truth_key("target"), TargetTruth(target_id="target", seq=step + 1, stamp_ns=stamp,
                                                     position_enu_m=(x, y), velocity_enu_mps=(vx, vy))))
        return out

    def flown(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        """Nothing of the flight is simulated beyond where the UAVs are."""


def run_loop(setup: AoaScenario, planner: str, seed: int, sigma0_deg: Sequence[float] = (1.0, 1.0, 1.0),
             clock: Callable[[], float] | None = None) -> LoopRecord:
    """One closed-loop run with ``len(sigma0_deg)`` UAVs (module docstring); ``clock`` times each plan job."""
    return run_alternated(setup, [planner], seed, sigma0_deg, clock)[planner]


def run_alternated(setup: AoaScenario, planners: Sequence[str], seed: int,
                   sigma0_deg: Sequence[float] = (1.0, 1.0, 1.0),
                   clock: Callable[[], float] | None = None) -> dict[str, LoopRecord]:
    """One closed-loop run of each planner on the same seed, stepped alternately: step ``k`` of every planner,
    then step ``k + 1``, the order rotated by one each step, so a change in the machine's load lands on all."""
    runs = [_LoopRun(setup, name, seed, sigma0_deg, clock) for name in planners]
    for k in range(setup.steps):
        for i in range(len(runs)):
            runs[(i + k) % len(runs)].step(k)
    return {name: run.record() for name, run in zip(planners, runs)}


class _LoopRun:
    """One planner's closed loop, stepped by the caller."""

    def __init__(self, setup: AoaScenario, planner: str, seed: int, sigma0_deg: Sequence[float],
                 clock: Callable[[], float] | None) -> None:
        scenario = aoa_scenario(setup, planner, sigma0_deg)
        self.setup, self.planner, self.seed, self.sigma0_deg = setup, planner, seed, tuple(sigma0_deg)
        self.iterations: dict[int, int] = {}
        self.loop = EngineLoop(scenario, None, np.random.default_rng([seed, 3]), IN_PROCESS,
                               planner=self._counted, clock=clock)
        self.scene = _AoaScene(setup, scenario, seed)
        start = VehicleState(setup.starts(len(sigma0_deg))[:, :2],
                             np.array([v.start_heading_rad for v in scenario.vehicles]),
                             np.full(len(sigma0_deg), setup.speed_mps),
                             np.array([v.altitude_m for v in scenario.vehicles]))
        self.airframes = IdealAirframes(self.scene.roster, start, self.loop.engine.tracker.max_turn_rate, setup.step_s,
                                        scenario.simulation.airframe.loiter_radius_m)
        self.loop.declare(self.scene.roster, 0.0)

    def _counted(self, job, config, rng):
        state, turn_rates, result = plan_job(job, config, rng)
        self.iterations[job.stamp_ns] = 0 if result is None else result.generations
        return state, turn_rates, result

    def step(self, k: int) -> None:
        fly_step(self.loop, self.scene, k, self.airframes)
        if k == self.setup.steps - 1:
            self.loop.finish(self.setup.steps * self.loop.step_s)

    def record(self) -> LoopRecord:
        return _record(self.setup, self.planner, self.seed, self.sigma0_deg, self.loop, self.scene, self.iterations)


def _record(setup: AoaScenario, planner: str, seed: int, sigma0_deg: Sequence[float], loop: EngineLoop,
            scene: _AoaScene, iterations: dict[int, int]) -> LoopRecord:
    """The run's record: the published track's squared error at every step, the bound along the flown paths."""
    steps = setup.steps
    stamps = [round(k * setup.step_s * NS_PER_S) for k in range(steps)]
    errors = np.full(steps, np.nan)
    for k, stamp in enumerate(stamps):
        tracks = loop.tracks.get(stamp)
        if tracks:
            d = np.asarray(tracks[-1].state[:2]) - scene.truth[k, :2]
            errors[k] = float(d @ d)
    solve_s = np.array([loop.plan_seconds.get(s, np.nan) for s in stamps[:-1]])
    counts = np.array([iterations.get(s, 0) for s in stamps[:-1]], dtype=int)
    after: NDArray[np.float64] = np.vstack([scene.heading[1:], scene.heading[-1:]])  # flown after each step
    xy = scene.vehicle_xyz[..., :2]
    sensors = setup.sensors(sigma0_deg)[0]
    return LoopRecord(planner, seed, errors, bound(setup, sensors, scene.vehicle_xyz, scene.truth), xy, after,
                      scene.truth[:, :2], solve_s, counts,
                      path_violations(setup, xy, after, scene.heading[0], scene.truth[:, :2]))
