"""The open-loop scene of the road-tracker comparison: a street car, three UAVs on fixed orbits, occluded sensing.

Per run (one scenario, one seed): the scenario's generated city; its car
(:class:`sim_vehicles.truth.target.StreetTarget`, the scenario's street speed and
turn probability; ``wang2012_urban``'s white-noise target is replaced by a street
car at the scenario's defaults); the scenario's first three UAVs at their
altitudes and speeds, each flying a fixed circle about the city's centre (radii
25%, 35% and 45% of the city's half-diagonal, starting 120 degrees apart),
whatever the car does; every step each UAV senses the car with the truth sensor
of :mod:`sim_vehicles.truth.sensor` (its own measurement formulas, the world's
exact line of sight, the sensor's range). Seeds: ``[seed, 1]`` drives the car,
``[seed, 2]`` the sensor noise, ``[seed, 3]`` a filter's own randomness; so the
estimators compared on one seed see the same path and the same detections.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from gcs.config import Scenario
from gcs.config.world import build_world
from gcs.core.world import World
from gcs.scenarios import load_scenario
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import start_state, target_model

__all__ = ["Scene", "Run", "load_scene", "simulate", "SCENARIOS", "ORBIT_FRACTIONS"]

SCENARIOS = ("downtown_dense", "fast_target", "wang2012_urban")
ORBIT_FRACTIONS = (0.1, 0.2, 0.3)
"""Orbit radii as fractions of the city's half-diagonal."""


@dataclass(frozen=True)
class Scene:
    """A scenario and its world, built once per process."""

    scenario: Scenario
    world: World


@dataclass(frozen=True)
class Run:
    """One run's truth and sensing: K steps, V vehicles.

    ``detections[k]`` lists ``(vehicle, values)`` of step ``k``.
    """

    seed: int
    step_s: float
    truth_xy: NDArray[np.float64]  # (K, 2)
    truth_v: NDArray[np.float64]  # (K, 2)
    vehicle_xyz: NDArray[np.float64]  # (K, V, 3)
    seen: NDArray[np.bool_]  # (K, V)
    detections: tuple[tuple[tuple[int, NDArray[np.float64]], ...], ...]


@lru_cache(maxsize=4)
def load_scene(name: str) -> Scene:
    """The shipped scenario ``name`` and its world."""
    scenario = load_scenario(name)
    return Scene(scenario, build_world(scenario))


def orbits(scene: Scene, steps: int, step_s: float) -> NDArray[np.float64]:
    """Vehicle positions (K, V, 3): circles about the city centre (module docstring)."""
    west, south, east, north = scene.world.bounds_m
    width, depth = east - west, north - south
    centre = np.array([0.5 * (west + east), 0.5 * (south + north)])
    half_diagonal = 0.5 * np.hypot(width, depth)
    vehicles = scene.scenario.vehicles[:3]
    t = np.arange(steps) * step_s
    out = np.zeros((steps, len(vehicles), 3))
    for i, vehicle in enumerate(vehicles):
        radius = ORBIT_FRACTIONS[i] * half_diagonal
        phase = 2.0 * np.pi * i / len(vehicles) + vehicle.speed_mps / radius * t
        out[:, i, 0] = centre[0] + radius * np.cos(phase)
        out[:, i, 1] = centre[1] + radius * np.sin(phase)
        out[:, i, 2] = vehicle.altitude_m
    return out


def simulate(scene: Scene, seed: int, duration_s: float | None = None) -> Run:
    """The truth path and every step's detections of one seed (module docstring)."""
    scenario = scene.scenario
    step_s = scenario.time.step_s
    steps = int(round((duration_s or scenario.time.duration_s) / step_s))
    truth_rng, sensor_rng = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
    model = target_model(scenario, scene.world, motion="streets")
    target = start_state(model, scenario, truth_rng)
    vehicles = orbits(scene, steps, step_s)
    sensors = [TargetSensor.from_config(scenario.sensor_for(v)) for v in scenario.vehicles[:3]]
    truth_xy, truth_v = np.zeros((steps, 2)), np.zeros((steps, 2))
    seen = np.zeros((steps, len(sensors)), dtype=bool)
    detections = []
    for k in range(steps):
        if k > 0:
            target = model.step(target, step_s, truth_rng)
        truth_xy[k], truth_v[k] = target.position, target.velocity
        target_xyz = np.array([target.position[0], target.position[1], 0.0])
        step = []
        for i, sensor in enumerate(sensors):
            obs = sensor.observe(target_xyz, vehicles[k, i:i + 1], scene.world.line_of_sight, sensor_rng)
            if obs.detected[0]:
                step.append((i, obs.values[0]))
                seen[k, i] = True
        detections.append(tuple(step))
    return Run(seed, step_s, truth_xy, truth_v, vehicles, seen, tuple(detections))
