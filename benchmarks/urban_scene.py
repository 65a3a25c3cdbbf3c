"""The simulated scene of ``gcs-bench urban``: one target in the city and the vehicles' messages about it.

The truth is the simulator's (:mod:`sim_vehicles.truth`): the scenario's target model
(:func:`~sim_vehicles.truth.target.target_model`, moved one decision step at a time, its draws from
``[seed, 1]``) and each vehicle's :class:`~sim_vehicles.truth.sensor.TargetSensor` (the world's line of
sight, the sensor's range; every vehicle's draws, in roster order, from ``[seed, 2]``), so that every
planner, and every navigation, meets the same target path and the same sensor noise on a seed. The
vehicles themselves are :class:`benchmarks.closed_loop.IdealAirframes`, flown by the engine's plans.

What the vehicles say about themselves (``navigation``):

* ``perfect``: their true positions (no ``vehicle_position_std_m``: exact) and headings, one ``NavReport`` a
  step with the true velocity: the paper's experiment, where the team's own states are known;
* ``reported``: their own navigation, as the simulated vehicles report it
  (:func:`sim_vehicles.scene.simple_navigation`: the GPS fix, or dead reckoning on the INS without one,
  its standard deviation growing with the distance flown), with nav reports of GPS and INS at the
  scenario's ``nav_rate_hz``; the engine fuses the reported positions with their standard deviation;
* ``skf``: the same messages, and the engine runs its own navigation on the nav reports
  (:class:`gcs.engine.navigation.FleetNavigator`, feng2019's SKF).

GPS (:class:`~sim_vehicles.truth.gps.GpsModel`, with the scenario's GPS-denied zones) and INS
(:class:`~sim_vehicles.truth.ins.InsModel`) are read at every tick of the vehicles' flight, each
vehicle's from its own stream ``[seed, 10 + i]``, the same whichever navigation is used. Each vehicle
enters the run with a fix of its start (the navigation it flew in with, zones or not): the engine's SKF
starts from a vehicle's first fix, as a real one would.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.core.kinematics import VehicleState
from gcs.core.world import World
from benchmarks.closed_loop import NS_PER_S, SUBSTEP_S
from protocols.keys import nav_key, report_key, truth_key
from protocols.messages import InsIncrement, NavReport, SensorReport, TargetTruth
from sim_vehicles.scene import gps_fix, simple_navigation, wire_measurement
from sim_vehicles.truth.gps import GpsModel
from sim_vehicles.truth.ins import InsModel
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import start_state, target_model

__all__ = ["NAVIGATIONS", "UrbanScene", "start_of"]

NAVIGATIONS = ("perfect", "reported", "skf")


def start_of(scenario: Scenario) -> VehicleState:
    """The scenario's vehicles at their start: position, heading, speed and altitude."""
    return VehicleState(np.array([v.start_enu_m for v in scenario.vehicles], dtype=np.float64),
                        np.array([v.start_heading_rad for v in scenario.vehicles], dtype=np.float64),
                        np.array([v.speed_mps for v in scenario.vehicles], dtype=np.float64),
                        np.array([v.altitude_m for v in scenario.vehicles], dtype=np.float64))


class UrbanScene:
    """The target, the vehicles' sensors and navigation, and their messages (module docstring)."""

    def __init__(self, scenario: Scenario, world: World, seed: int, steps: int, motion: str | None = None,
                 navigation: str = "perfect") -> None:
        if navigation not in NAVIGATIONS:
            raise ValueError(f"unknown navigation {navigation!r}; expected one of {', '.join(NAVIGATIONS)}")
        self.scenario, self.world, self.navigation = scenario, world, navigation
        self.roster = [v.id for v in scenario.vehicles]
        self.step_s = scenario.time.step_s
        self.frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        self.truth_rng, self.sensor_rng = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
        self.model = target_model(scenario, world, motion)
        self.target = start_state(self.model, scenario, self.truth_rng)
        self.sensors = tuple(TargetSensor.from_config(scenario.sensor_for(v)) for v in scenario.vehicles)
        self.nav_every = max(1, round(1.0 / (scenario.simulation.nav_rate_hz * SUBSTEP_S)))
        count = len(self.roster)
        self.target_xy = np.zeros((steps, 2))
        self.vehicle_xy = np.zeros((steps, count, 2))
        self.vehicle_heading = np.zeros((steps, count))
        self.violations = np.zeros((steps, count), dtype=bool)
        self.gps_fix = np.ones((steps, count), dtype=bool)
        self.nav_error_m = np.zeros((steps, count))
        self._step = 0
        # GPS and INS are simulated with the vehicles' own navigation, and in GPS-denied zones for the outages
        self._own = (_OwnNavigation(scenario, seed, start_of(scenario))
                     if navigation != "perfect" or scenario.gps_denied else None)
        self._reports_own = navigation != "perfect"
        self._seq = 0

    # ------------------------------------------------------------------ messages

    def messages(self, step: int, substep: int, vehicles: VehicleState | None) -> list[tuple[str, object]]:
        """At a step's first tick the nav reports, the sensor reports and the truth; nav reports in between at
        the scenario's nav rate (with the vehicles' own navigation)."""
        assert vehicles is not None
        stamp = round((step * self.step_s + substep * SUBSTEP_S) * NS_PER_S)
        out: list[tuple[str, object]] = []
        if substep % self.nav_every == 0 and (self._reports_own or substep == 0):
            self._seq += 1
            out += [(nav_key(v), self._nav_report(i, v, vehicles, stamp)) for i, v in enumerate(self.roster)]
        if substep != 0:
            return out
        self._step = step
        if step > 0:
            self.target = self.model.step(self.target, self.step_s, self.truth_rng)
        target_xyz = np.array([self.target.position[0], self.target.position[1], 0.0])
        self.target_xy[step], self.vehicle_xy[step] = self.target.position, vehicles.xy
        self.vehicle_heading[step] = vehicles.heading
        if self._own is not None:
            self.gps_fix[step] = self._own.fixes
        if self._reports_own:
            self.nav_error_m[step] = np.hypot(*(self._own.xyz[:, :2] - vehicles.xy).T)
        for i, (vehicle_id, sensor) in enumerate(zip(self.roster, self.sensors)):
            where = vehicles.xyz[i]
            observed = sensor.observe(target_xyz, where[None], self.world.line_of_sight, self.sensor_rng)
            detections = ()
            if observed.detected[0]:
                std = sensor.std_at(float(np.linalg.norm(target_xyz - where)))
                detections = (wire_measurement(sensor.components, observed.values[0], std),)
            own, std_m = (self._own.xyz[i], float(self._own.std_m[i])) if self._reports_own else (where, None)
            out.append((report_key(vehicle_id), SensorReport(
                vehicle_id=vehicle_id, seq=step + 1, stamp_ns=stamp, vehicle_position_enu_m=tuple(map(float, own)),
                vehicle_position_std_m=std_m, detections=detections)))
        out.append((truth_key(self.scenario.target.id), TargetTruth(
            target_id=self.scenario.target.id, seq=step + 1, stamp_ns=stamp,
            position_enu_m=(float(self.target.position[0]), float(self.target.position[1])),
            velocity_enu_mps=(float(self.target.velocity[0]), float(self.target.velocity[1])))))
        return out

    def _nav_report(self, i: int, vehicle_id: str, vehicles: VehicleState, stamp: int) -> NavReport:
        heading = float(vehicles.heading[i])
        velocity = (float(vehicles.speed[i] * math.cos(heading)), float(vehicles.speed[i] * math.sin(heading)), 0.0)
        if not self._reports_own:
            return NavReport(vehicle_id=vehicle_id, seq=self._seq, stamp_ns=stamp, velocity_enu_mps=velocity,
                             heading_rad=heading)
        gps, ins = self._own.report(i, self.frame)
        return NavReport(vehicle_id=vehicle_id, seq=self._seq, stamp_ns=stamp, gps=gps, ins=ins,
                         velocity_enu_mps=velocity if gps is not None or ins is None else None,
                         heading_rad=float(wrap_angle(self._own.heading[i])))

    # -------------------------------------------------------------------- flight

    def flown(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        """Airspace entered during the tick's flight; the vehicles' GPS and INS read."""
        if len(self.world.airspace):
            self.violations[self._step] |= self.world.in_restricted(after.xyz)
        if self._own is not None:
            self._own.fly(before, after, dt)


class _OwnNavigation:
    """Every vehicle's GPS, INS and own navigation (:func:`sim_vehicles.scene.simple_navigation`)."""

    def __init__(self, scenario: Scenario, seed: int, start: VehicleState) -> None:
        self.gps_model, self.ins_model = GpsModel.from_scenario(scenario), InsModel(scenario.simulation.ins)
        self.rngs = [np.random.default_rng([seed, 10 + i]) for i in range(len(start))]
        self.gps_states, self.readings = [], []
        before = GpsModel(self.gps_model.config)  # the receiver before the run: no zone
        for i, rng in enumerate(self.rngs):
            state = self.gps_model.start(rng)
            state, reading = before.read(state, start.xyz[i], 0.0, rng)
            self.gps_states.append(state)
            self.readings.append(reading)
        self.xyz: NDArray[np.float64] = start.xyz.copy()
        self.heading = start.heading.copy()
        self.std_m = np.array([r.horizontal_std_m for r in self.readings])
        self.ins = np.zeros((len(start), 3))  # distance, turn and seconds since the last nav report

    @property
    def fixes(self) -> NDArray[np.bool_]:
        return np.array([r.position_enu_m is not None for r in self.readings])

    def fly(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        for i, rng in enumerate(self.rngs):
            turn = float(wrap_angle(after.heading[i] - before.heading[i]))
            distance, measured = self.ins_model.increment(float(np.hypot(*(after.xy[i] - before.xy[i]))), turn, dt,
                                                          rng)
            self.gps_states[i], self.readings[i] = self.gps_model.read(self.gps_states[i], after.xyz[i], dt, rng)
            self.ins[i] += (distance, measured, dt)
            self.xyz[i], self.heading[i], self.std_m[i] = simple_navigation(
                self.xyz[i], float(self.heading[i]), float(self.std_m[i]), self.readings[i], float(after.heading[i]),
                float(after.altitude[i]), distance, measured)

    def report(self, i: int, frame: LocalFrame):
        """The GPS fix and the INS increments since the last report of vehicle ``i``."""
        distance, turn, seconds = self.ins[i]
        self.ins[i] = 0.0
        ins = InsIncrement(dt_s=float(seconds), distance_m=max(float(distance), 0.0),
                           heading_change_rad=float(turn)) if seconds > 0.0 else None
        return gps_fix(frame, self.readings[i]), ins
