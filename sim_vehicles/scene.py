"""The simulated scene: every vehicle's airframe, GPS, INS and sensor, and the ground targets.

:class:`Scene` advances the truth by physics steps and produces the wire
messages the vehicles publish (``SensorReport``, ``NavReport``, and a
``TargetTruth`` per target). It owns no sockets and reads no clock: simulation
time is its own ``elapsed_s``, and wire stamps are ``epoch_ns + elapsed``.
Randomness comes from one generator per stream (``[target]``; each vehicle's
GPS, INS and sensor; then each of ``[[targets]]``), all spawned from one seed,
so a stream's draws do not depend on how often another stream is sampled.

A scan (:meth:`Scene.sensor_report`) measures every target in range and in
sight (occlusion by the city's buildings), keeps each with the sensor's
``detection_probability``, adds ``Poisson(clutter_rate)`` false detections
uniform over the ground in the field (:func:`~sim_vehicles.truth.clutter.clutter_points`)
and lists them in random order, without identity. Its draws from the vehicle's
sensor stream: the noise of every target (drawn in sight or not), then, only when
``detection_probability < 1``, one uniform per target, only when ``clutter_rate > 0``
the clutter, and only for two detections or more the order. One target, certain
detection and no clutter therefore draw exactly the noise of that one target.

A vehicle's own navigation (what ``vehicle_position_enu_m`` reports) is the
simplest honest one: the GPS fix when there is one; in a GPS-denied zone, dead
reckoning from the last fix with the INS increments (feng2019 eq. 1, drawn every
physics step and summed into each ``NavReport``), its
standard deviation growing by :data:`DEAD_RECKONING_GROWTH` per metre flown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario, SensorConfig, VehicleConfig
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.core.world import World
from gcs.core.world.los import line_of_sight
from protocols.messages import GpsFix, InsIncrement, Measurement, NavReport, SensorReport, TargetTruth
from sim_vehicles.truth.fixed_wing import Airframe, AirframeState, Guidance
from sim_vehicles.truth.gps import GpsModel, GpsReading, GpsState
from sim_vehicles.truth.ins import InsModel
from sim_vehicles.truth.clutter import clutter_points, ground_disc_radius
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import TargetModel, TargetState, start_state, target_model

__all__ = ["Scene", "SimTarget", "SimVehicle", "DEAD_RECKONING_GROWTH", "simple_navigation", "gps_fix",
           "wire_measurement"]

DEAD_RECKONING_GROWTH = 0.05
"""Growth of the dead-reckoned position's 1-sigma per metre flown without GPS (ours)."""

NS_PER_S = 1_000_000_000


@dataclass
class SimVehicle:
    """One vehicle's truth and sensor state (mutable: the scene advances it)."""

    config: VehicleConfig
    airframe: Airframe
    state: AirframeState
    gps_model: GpsModel
    gps_state: GpsState
    gps: GpsReading
    ins_model: InsModel
    sensor: TargetSensor
    rng_gps: np.random.Generator
    rng_ins: np.random.Generator
    rng_sensor: np.random.Generator
    nav_position_enu_m: np.ndarray
    nav_heading_rad: float
    nav_std_m: float
    ins_distance_m: float = 0.0
    ins_turn_rad: float = 0.0
    last_nav_ns: int = 0
    report_seq: int = 0
    nav_seq: int = 0


@dataclass
class SimTarget:
    """One ground target's truth (mutable: the scene advances it)."""

    id: str
    model: TargetModel
    state: TargetState
    rng: np.random.Generator
    truth_seq: int = 0

    @property
    def xyz(self) -> np.ndarray:
        """Position, ENU metres, on the ground (z = 0)."""
        return np.array([self.state.position[0], self.state.position[1], 0.0])


class Scene:
    """Truth of one scenario, advanced in physics steps.

    Parameters
    ----------
    scenario : Scenario
    world : World
        The city (for occlusion and the target's streets).
    seed : int
        Seed of every random stream.
    epoch_ns : int
        Wire stamp of simulation time zero.
    base_dir : Path or None
        Where relative files of the scenario (a scripted target path) live.
    only : tuple of vehicle ids, or None
        Simulate only these vehicles (the target is always simulated); their
        random streams are the same as in a scene of every vehicle.
    """

    def __init__(self, scenario: Scenario, world: World, seed: int, epoch_ns: int = 0,
                 base_dir: Path | None = None, only: tuple[str, ...] | None = None) -> None:
        self.scenario = scenario
        self.world = world
        self.epoch_ns = int(epoch_ns)
        self.frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        sim = scenario.simulation
        self.wind = (float(sim.wind_enu_mps[0]), float(sim.wind_enu_mps[1]))
        self.elapsed_ns = 0
        vehicles = len(scenario.vehicles)
        streams = np.random.SeedSequence(seed).spawn(1 + 3 * vehicles + len(scenario.targets))
        self.targets: list[SimTarget] = []
        for index, target_cfg in enumerate(scenario.all_targets):
            rng = np.random.default_rng(streams[0 if index == 0 else 3 * vehicles + index])
            model = target_model(scenario, world, base_dir=base_dir, target=target_cfg)
            self.targets.append(SimTarget(target_cfg.id, model, start_state(model, scenario, rng, target_cfg), rng))
        gps_model = GpsModel.from_scenario(scenario)
        self.vehicles: dict[str, SimVehicle] = {}
        unknown = sorted(set(only or ()) - {v.id for v in scenario.vehicles})
        if unknown:
            raise ValueError(f"unknown vehicles {unknown}; the scenario has {[v.id for v in scenario.vehicles]}")
        for index, cfg in enumerate(scenario.vehicles):
            if only is not None and cfg.id not in only:
                continue  # its streams stay unused, so every vehicle draws the same noise in any split
            rng_gps, rng_ins, rng_sensor = (np.random.default_rng(s) for s in streams[1 + 3 * index: 4 + 3 * index])
            grounded = sim.start_on_ground  # parked at home height until its autopilot takes off
            state = AirframeState(np.array([cfg.start_enu_m[0], cfg.start_enu_m[1], 0.0 if grounded else cfg.altitude_m]),
                                  heading_rad=cfg.start_heading_rad, roll_rad=0.0,
                                  airspeed_mps=0.0 if grounded else cfg.speed_mps)
            gps_state = gps_model.start(rng_gps)
            gps_state, reading = gps_model.read(gps_state, state.position_enu_m, 0.0, rng_gps)
            self.vehicles[cfg.id] = SimVehicle(
                config=cfg, airframe=Airframe(sim.airframe, cfg.max_turn_rate_rad_s, self.wind), state=state,
                gps_model=gps_model, gps_state=gps_state, gps=reading, ins_model=InsModel(sim.ins),
                sensor=TargetSensor.from_config(scenario.sensor_for(cfg)),
                rng_gps=rng_gps, rng_ins=rng_ins, rng_sensor=rng_sensor,
                nav_position_enu_m=state.position_enu_m.copy(), nav_heading_rad=state.heading_rad,
                nav_std_m=reading.horizontal_std_m)

    # ------------------------------------------------------------------ truth

    @property
    def elapsed_s(self) -> float:
        """Simulation time, seconds (kept as integer nanoseconds, so steps never accumulate rounding)."""
        return self.elapsed_ns / NS_PER_S

    @property
    def stamp_ns(self) -> int:
        """Wire stamp of the current simulation time."""
        return self.epoch_ns + self.elapsed_ns

    def default_guidance(self, vehicle_id: str) -> Guidance:
        """Loiter about the start point at the scenario's altitude and speed (no autopilot attached)."""
        cfg = self.vehicles[vehicle_id].config
        return Guidance(kind="loiter", altitude_m=cfg.altitude_m, airspeed_mps=cfg.speed_mps,
                        point_enu_m=(cfg.start_enu_m[0], cfg.start_enu_m[1]),
                        radius_m=self.scenario.simulation.airframe.loiter_radius_m)

    def advance(self, dt: float, guidance: dict[str, Guidance]) -> None:
        """Fly every vehicle ``dt`` seconds under its guidance, move the target, sample GPS."""
        for vehicle_id, vehicle in self.vehicles.items():
            command = guidance.get(vehicle_id) or self.default_guidance(vehicle_id)
            before = vehicle.state
            vehicle.state = vehicle.airframe.step(before, command, dt)
            vehicle.gps_state, vehicle.gps = vehicle.gps_model.read(vehicle.gps_state, vehicle.state.position_enu_m,
                                                                    dt, vehicle.rng_gps)
            self._navigate(vehicle, before, dt)
        self._move_targets(dt)
        self.elapsed_ns += round(dt * NS_PER_S)

    def _move_targets(self, dt: float) -> None:
        for target in self.targets:
            target.state = target.model.step(target.state, dt, target.rng)

    def skip_target(self, dt: float) -> None:
        """Move only the targets ``dt`` seconds (their draws are those :meth:`advance` makes): a process joining a
        run in flight brings the targets to the others' time; its vehicles start afresh from there."""
        self._move_targets(dt)
        self.elapsed_ns += round(dt * NS_PER_S)
        for vehicle in self.vehicles.values():
            vehicle.last_nav_ns = self.elapsed_ns  # the first INS increment covers flight, not the skip
            vehicle.ins_distance_m = vehicle.ins_turn_rad = 0.0

    @property
    def target(self) -> TargetState:
        """The truth of ``[target]``, the scenario's first target."""
        return self.targets[0].state

    @property
    def target_xyz(self) -> np.ndarray:
        """``[target]``'s truth, ENU metres (on the ground, z = 0)."""
        return self.targets[0].xyz

    # --------------------------------------------------------------- messages

    def _scan(self, vehicle: SimVehicle, sensor_config: SensorConfig) -> list[Measurement]:
        """One scan's detections by ``vehicle`` (see the module docstring for what is drawn, in which order)."""
        buildings = self.world.buildings
        position = vehicle.state.position_enu_m
        sensor, rng = vehicle.sensor, vehicle.rng_sensor

        def clear(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return line_of_sight(buildings, a, b)

        found, in_sight = [], []
        for target in self.targets:
            observation = sensor.observe(target.xyz, position[None], clear, rng)
            in_sight.append(bool(observation.detected[0]))
            if in_sight[-1]:
                found.append((observation.values[0], sensor.std_at(float(np.linalg.norm(target.xyz - position)))))
        pd = sensor_config.detection_probability
        if pd < 1.0:  # one draw per target, in sight or not, so that the stream does not depend on the geometry
            kept = (rng.random(len(self.targets)) < pd)[np.array(in_sight, dtype=bool)]
            found = [f for f, keep in zip(found, kept) if keep]
        if sensor_config.clutter_rate > 0.0:
            radius = float(ground_disc_radius(position[None], sensor.max_range_m, 0.0)[0])
            points = clutter_points(position[:2], radius, sensor_config.clutter_rate, rng)
            values, stds = sensor.measure_points(np.column_stack([points, np.zeros(len(points))]), position, rng)
            found += list(zip(values, stds))
        if len(found) > 1:
            found = [found[i] for i in rng.permutation(len(found))]
        return [wire_measurement(sensor.components, values, stds) for values, stds in found]

    def sensor_report(self, vehicle_id: str) -> SensorReport:
        """The vehicle's sensor scans now: its detections of the targets and of clutter (module docstring)."""
        vehicle = self.vehicles[vehicle_id]
        detections = self._scan(vehicle, self.scenario.sensor_for(vehicle.config))
        vehicle.report_seq += 1
        return SensorReport(
            vehicle_id=vehicle_id, seq=vehicle.report_seq, stamp_ns=self.stamp_ns,
            vehicle_position_enu_m=_xyz(vehicle.nav_position_enu_m),
            vehicle_position_std_m=float(vehicle.nav_std_m), detections=tuple(detections))

    def nav_report(self, vehicle_id: str) -> NavReport:
        """GPS fix (when there is one) and the INS increments accumulated since the previous nav report."""
        vehicle = self.vehicles[vehicle_id]
        ins = None
        dt = (self.elapsed_ns - vehicle.last_nav_ns) / NS_PER_S
        if dt > 0.0:
            ins = InsIncrement(dt_s=dt, distance_m=max(vehicle.ins_distance_m, 0.0),
                               heading_change_rad=vehicle.ins_turn_rad)
        vehicle.last_nav_ns, vehicle.ins_distance_m, vehicle.ins_turn_rad = self.elapsed_ns, 0.0, 0.0
        gps = gps_fix(self.frame, vehicle.gps)
        vehicle.nav_seq += 1
        velocity = None
        if gps is not None or ins is None:  # GNSS velocity (accurate to centimetres per second: truth)
            velocity = _xyz(vehicle.state.ground_velocity(self.wind))
        return NavReport(vehicle_id=vehicle_id, seq=vehicle.nav_seq, stamp_ns=self.stamp_ns, gps=gps, ins=ins,
                         velocity_enu_mps=velocity, heading_rad=wrap_angle(vehicle.nav_heading_rad),
                         turn_rate_rad_s=float(vehicle.state.turn_rate_rad_s))

    def truths(self) -> list[TargetTruth]:
        """Every target's truth now, ``[target]`` first (published by the simulator for scoring and display only)."""
        out = []
        for target in self.targets:
            target.truth_seq += 1
            out.append(TargetTruth(target_id=target.id, seq=target.truth_seq, stamp_ns=self.stamp_ns,
                                   position_enu_m=(float(target.state.position[0]), float(target.state.position[1])),
                                   velocity_enu_mps=(float(target.state.velocity[0]), float(target.state.velocity[1]))))
        return out

    def _navigate(self, vehicle: SimVehicle, before: AirframeState, dt: float) -> None:
        """One physics step of the vehicle's own navigation: INS increments (feng2019 eq. 1), then
        the GPS fix when there is one, else dead reckoning from the last fix."""
        true_distance = vehicle.state.distance_m - before.distance_m
        true_turn = math.remainder(vehicle.state.heading_rad - before.heading_rad, 2.0 * math.pi)
        distance, turn = vehicle.ins_model.increment(true_distance, true_turn, dt, vehicle.rng_ins)
        vehicle.ins_distance_m += distance
        vehicle.ins_turn_rad += turn
        vehicle.nav_position_enu_m, vehicle.nav_heading_rad, vehicle.nav_std_m = simple_navigation(
            vehicle.nav_position_enu_m, vehicle.nav_heading_rad, vehicle.nav_std_m, vehicle.gps,
            vehicle.state.heading_rad, vehicle.state.position_enu_m[2], distance, turn)


_FIELDS = {"range": ("range_m", "range_std_m"), "azimuth": ("azimuth_rad", "azimuth_std_rad"),
           "elevation": ("elevation_rad", "elevation_std_rad")}
"""The ``Measurement`` fields of each sensor component: its value and its standard deviation."""


def wire_measurement(components: tuple[str, ...], values: np.ndarray, stds: np.ndarray) -> Measurement:
    """The wire form of one detection's measured components and their standard deviations."""
    fields: dict[str, float] = {}
    for component, value, std in zip(components, values, stds):
        name, std_name = _FIELDS[component]
        fields[name], fields[std_name] = float(value), float(std)
    return Measurement(**fields)


def gps_fix(frame: LocalFrame, reading: GpsReading) -> GpsFix | None:
    """The wire form of a GPS reading (geodetic, about the scenario's origin ``frame``); None without a fix."""
    if reading.position_enu_m is None:
        return None
    lat, lon, _ = frame.to_geodetic(reading.position_enu_m)
    return GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=frame.height_m + float(reading.position_enu_m[2]),
                  fix_type=reading.fix_type, h_acc_m=reading.horizontal_std_m, v_acc_m=reading.vertical_std_m,
                  satellites=reading.satellites)


def simple_navigation(position_enu_m: np.ndarray, heading_rad: float, std_m: float, gps: GpsReading,
                      true_heading_rad: float, true_altitude_m: float, distance_m: float,
                      turn_rad: float) -> tuple[np.ndarray, float, float]:
    """The simulated vehicles' own navigation over one INS increment: ``(position (3,), heading, std)``.

    With a fix: the fix, the true heading (a compass) and the fix's accuracy. Without:
    dead reckoning by feng2019 eq. (1) from the previous values, the altitude held by the
    barometer (the truth's) and the standard deviation grown by :data:`DEAD_RECKONING_GROWTH`
    per metre.
    """
    if gps.position_enu_m is not None:
        return gps.position_enu_m.copy(), true_heading_rad, gps.horizontal_std_m
    mid = heading_rad + 0.5 * turn_rad
    position = position_enu_m + np.array([distance_m * math.cos(mid), distance_m * math.sin(mid), 0.0])
    position[2] = true_altitude_m
    return position, heading_rad + turn_rad, std_m + DEAD_RECKONING_GROWTH * distance_m


def _xyz(vector: NDArray[np.float64]) -> tuple[float, float, float]:
    """An ENU vector (3,) as three Python floats, as the wire messages hold it."""
    return float(vector[0]), float(vector[1]), float(vector[2])
