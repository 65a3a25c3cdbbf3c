"""Scenario configuration: frozen msgspec Structs decoded from TOML and validated.

A scenario file describes one experiment: the geodetic origin of the local ENU
frame, the time step, the city, restricted airspace, the vehicles with their
sensors, the ground target, the estimator and the planner. Units are SI and
radians, and every field name that carries a unit says it (``altitude_m``,
``max_turn_rate_rad_s``).

Errors name the bad key with a msgspec-style path, e.g.
``wang2012_urban.toml: $.vehicles[1].speed_mps: Expected `float` > 0.0``.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import msgspec

from gcs.config.base import Config as _Config
from gcs.config.base import Identifier, Metres, NonNegative, Point2, Positive, Radians
from gcs.config.city import CityConfig, SourceConfig
from gcs.config.estimator import EstimatorConfig, RoadEstimatorConfig, check_estimator, estimator_kind
from gcs.config.multitarget import MultiTargetConfig, check_multitarget
from gcs.config.planner import PlannerConfig, SightConfig, check_planner
from gcs.config.simulation import (AUTOPILOT_PERSONALITIES, AirframeConfig, GpsConfig, GpsDeniedZone, InsConfig,
                                   SimulationConfig)

__all__ = [
    "ScenarioError",
    "Origin",
    "TimeConfig",
    "CityConfig",
    "SourceConfig",
    "RestrictedAirspace",
    "SensorConfig",
    "VehicleConfig",
    "TargetConfig",
    "EstimatorConfig",
    "RoadEstimatorConfig",
    "estimator_kind",
    "SightConfig",
    "PlannerConfig",
    "MultiTargetConfig",
    "Scenario",
    "validate_scenario",
]

class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message names the file and the key."""


class Origin(_Config, frozen=True):
    """Geodetic origin of the local ENU frame (WGS84 degrees, metres above the ellipsoid)."""

    lat_deg: Annotated[float, msgspec.Meta(ge=-90.0, le=90.0)]
    lon_deg: Annotated[float, msgspec.Meta(ge=-180.0, le=180.0)]
    height_m: Metres = 0.0


class TimeConfig(_Config, frozen=True):
    """Decision step and run length, seconds."""

    step_s: Positive = 1.0
    duration_s: Positive = 300.0


class RestrictedAirspace(_Config, frozen=True):
    """A no-fly zone (wang2012 eq. 5): a polygon in ENU metres with an altitude band."""

    name: Identifier
    polygon_enu_m: Annotated[list[Point2], msgspec.Meta(min_length=3)]
    floor_m: Metres = 0.0
    ceiling_m: Metres = 10_000.0


class SensorConfig(_Config, frozen=True):
    """Target sensor on a vehicle (wang2012 eq. 3-4; zuo2021 eq. 2 for distance-dependent noise).

    ``kind``: ``range_bearing`` measures range, azimuth and elevation;
    ``bearing_only`` measures azimuth (and elevation when ``elevation`` is true and
    ``elevation_std_rad`` is set).
    ``noise``: ``constant`` standard deviations, or ``distance_dependent``
    (zuo2021 eq. 2: sigma^2 = sigma0^2 r^2 / r0^2 beyond ``reference_range_m``).
    """

    kind: Literal["range_bearing", "bearing_only"] = "range_bearing"
    range_std_m: Positive | None = 10.0
    azimuth_std_rad: Positive = 0.05
    elevation_std_rad: Positive | None = 0.05
    max_range_m: Positive = 5000.0
    noise: Literal["constant", "distance_dependent"] = "constant"
    reference_range_m: Positive = 1500.0
    elevation: bool = True
    """Whether a ``bearing_only`` sensor also measures elevation (TOML cannot unset ``elevation_std_rad``)."""
    detection_probability: Annotated[float, msgspec.Meta(ge=0.0, le=1.0)] = 1.0
    """Probability that the simulated sensor detects a target in its field and in sight, per scan."""
    clutter_rate: Annotated[float, msgspec.Meta(ge=0.0, le=32.0)] = 0.0
    """Mean number of false detections per simulated scan (Poisson), uniform over the ground in the field."""

    def layout(self) -> tuple[tuple[str, ...], tuple[float, ...]]:
        """Measured components and their standard deviations, in measurement-vector order.

        ``range_bearing``: range, azimuth, elevation; ``bearing_only``: azimuth,
        plus elevation when ``elevation`` is true and ``elevation_std_rad`` is set.

        Raises
        ------
        ValueError
            ``range_bearing`` without ``range_std_m`` or ``elevation_std_rad``.
        """
        if self.kind == "range_bearing":
            if self.range_std_m is None or self.elevation_std_rad is None:
                raise ValueError("a range_bearing sensor needs range_std_m and elevation_std_rad")
            return ("range", "azimuth", "elevation"), (self.range_std_m, self.azimuth_std_rad, self.elevation_std_rad)
        if self.elevation_std_rad is None or not self.elevation:
            return ("azimuth",), (self.azimuth_std_rad,)
        return ("azimuth", "elevation"), (self.azimuth_std_rad, self.elevation_std_rad)


class VehicleConfig(_Config, frozen=True):
    """One fixed-wing UAV (wang2012 eq. 1: constant speed and altitude, bounded turn rate)."""

    id: Identifier
    sysid: Annotated[int, msgspec.Meta(ge=1, le=250)]
    altitude_m: Positive
    speed_mps: Positive
    max_turn_rate_rad_s: Positive
    start_enu_m: Point2
    start_heading_rad: Radians = 0.0
    sensor: SensorConfig | None = None
    """Overrides the scenario's ``[sensor]`` for this vehicle when given."""
    autopilot: str | None = None
    """Overrides ``[simulation] autopilot`` for this vehicle when given."""


class TargetConfig(_Config, frozen=True):
    """The ground target's truth model (wang2012 eq. 2).

    ``white_noise_acceleration``: continuous white-noise acceleration of power
    spectral density ``accel_psd_m2_s3`` (the per-step velocity noise standard
    deviation is ``sqrt(accel_psd_m2_s3 * step_s)``; wang2012 section 5 gives
    1.4 m/s, i.e. 1.96 m^2/s^3 at 1 s), speed capped at ``max_speed_mps``.
    ``streets``: drives the roads at ``street_speed_mps``, turning at an
    intersection with ``turn_probability``: a generated city's street grid, or the
    road graph of any other city that has one (``[city] roads_geojson``).
    ``scripted``: follows the time-stamped path of ``path_file`` or ``path``.
    """

    id: Identifier = "target"
    motion: Literal["white_noise_acceleration", "streets", "scripted"] = "white_noise_acceleration"
    start_enu_m: Point2 = (1500.0, 1500.0)
    start_velocity_mps: Point2 = (0.0, 0.0)
    accel_psd_m2_s3: NonNegative = 1.96
    max_speed_mps: Positive = 15.0
    path_file: str | None = None
    path: list[tuple[NonNegative, float, float]] = []
    """``scripted``: the path inline, rows ``[t_s, x_m, y_m]`` (instead of ``path_file``)."""
    street_speed_mps: Positive = 10.0
    """``streets``: cruising speed along the roads (capped by ``max_speed_mps``)."""
    turn_probability: Annotated[float, msgspec.Meta(ge=0.0, le=1.0)] = 0.5
    """``streets``: probability of leaving the straight road at an intersection."""


class Scenario(_Config, frozen=True, kw_only=True):
    """A whole experiment; the default is wang2012 section 5."""

    name: Identifier
    description: str = ""
    source: SourceConfig | None = None
    """``[source]``: where the city's data came from and its licence notice (a city built from OpenStreetMap)."""
    origin: Origin
    time: TimeConfig = TimeConfig()
    city: CityConfig = CityConfig()
    restricted: list[RestrictedAirspace] = []
    sensor: SensorConfig = SensorConfig()
    vehicles: Annotated[list[VehicleConfig], msgspec.Meta(min_length=1)]
    target: TargetConfig = TargetConfig()
    targets: Annotated[list[TargetConfig], msgspec.Meta(max_length=63)] = []
    """Further ground targets (``[[targets]]``), simulated alongside ``[target]``, the one the
    single-target estimator's track is named for."""
    estimator: EstimatorConfig = EstimatorConfig()
    planner: PlannerConfig = PlannerConfig()
    multitarget: MultiTargetConfig | None = None
    """``[multitarget]``: track every target (:mod:`gcs.config.multitarget`); None: the one of ``[estimator]``."""
    simulation: SimulationConfig = SimulationConfig()
    gps_denied: list[GpsDeniedZone] = []

    def sensor_for(self, vehicle: VehicleConfig) -> SensorConfig:
        """The sensor a vehicle carries: its own override, else the scenario's."""
        return vehicle.sensor if vehicle.sensor is not None else self.sensor

    @property
    def all_targets(self) -> tuple[TargetConfig, ...]:
        """Every simulated target: ``[target]`` first, then ``[[targets]]`` in order."""
        return (self.target, *self.targets)

    def autopilot_for(self, vehicle: VehicleConfig) -> str:
        """The autopilot personality a simulated vehicle flies: its own, else ``[simulation] autopilot``."""
        return vehicle.autopilot if vehicle.autopilot is not None else self.simulation.autopilot


def _check_sensor(sensor: SensorConfig, path: str) -> list[str]:
    problems = []
    if sensor.kind == "range_bearing" and sensor.range_std_m is None:
        problems.append(f"{path}.range_std_m: required when kind = 'range_bearing'")
    return problems


def _check_autopilot(name: str | None, path: str) -> list[str]:
    if name is None or name in AUTOPILOT_PERSONALITIES:
        return []
    return [f"{path}: unknown autopilot {name!r}; expected one of: {', '.join(AUTOPILOT_PERSONALITIES)}"]


def _outside(point: tuple[float, float], size: tuple[float, float]) -> bool:
    """Whether ``point`` lies outside the city rectangle ``[0, width] x [0, depth]``."""
    return not (0.0 <= point[0] <= size[0] and 0.0 <= point[1] <= size[1])


def _check_target(target: TargetConfig, path: str, size: tuple[float, float] | None) -> list[str]:
    problems = []
    if size is not None and _outside(target.start_enu_m, size):
        width, height = size
        problems.append(f"{path}.start_enu_m: {target.start_enu_m} is outside the city [0, {width}] x [0, {height}]")
    if target.motion == "scripted" and not target.path_file and not target.path:
        problems.append(f"{path}.path_file: required when motion = 'scripted' (or give path)")
    if target.path_file and target.path:
        problems.append(f"{path}.path: give path_file or path, not both")
    times = [row[0] for row in target.path]
    if any(later <= earlier for earlier, later in zip(times, times[1:])):
        problems.append(f"{path}.path: the times t_s must be strictly increasing")
    return problems


def validate_scenario(scenario: Scenario) -> Scenario:
    """Check the rules a schema cannot express; raise ScenarioError naming every bad key.

    Rules: vehicle ids, target ids and MAVLink system ids are unique; every start point lies
    inside the city rectangle (of a city that has one: a city read from files is framed on its
    content and its start points, :attr:`CityConfig.framed_on_content`); a scripted target has one path; building heights are ordered; airspace bands
    are ordered; a GeoJSON city names its file; sensors that measure range have
    a range standard deviation; autopilot personalities and the planner are known names; ``[estimator]``'s
    rules (:func:`gcs.config.estimator.check_estimator`); ``[multitarget]``'s rules
    (:func:`gcs.config.multitarget.check_multitarget`).
    """
    problems: list[str] = []
    size = None if scenario.city.framed_on_content else scenario.city.size_m
    seen_ids: dict[str, int] = {}
    seen_sysids: dict[int, int] = {}
    for index, vehicle in enumerate(scenario.vehicles):
        path = f"$.vehicles[{index}]"
        if vehicle.id in seen_ids:
            problems.append(f"{path}.id: duplicate vehicle id {vehicle.id!r} (also $.vehicles[{seen_ids[vehicle.id]}])")
        seen_ids.setdefault(vehicle.id, index)
        if vehicle.sysid in seen_sysids:
            problems.append(f"{path}.sysid: duplicate MAVLink system id {vehicle.sysid} (also $.vehicles[{seen_sysids[vehicle.sysid]}])")
        seen_sysids.setdefault(vehicle.sysid, index)
        if size is not None and _outside(vehicle.start_enu_m, size):
            problems.append(f"{path}.start_enu_m: {vehicle.start_enu_m} is outside the city "
                            f"[0, {size[0]}] x [0, {size[1]}]")
        if vehicle.sensor is not None:
            problems += _check_sensor(vehicle.sensor, f"{path}.sensor")
        problems += _check_autopilot(vehicle.autopilot, f"{path}.autopilot")
    problems += _check_autopilot(scenario.simulation.autopilot, "$.simulation.autopilot")
    problems += _check_sensor(scenario.sensor, "$.sensor")
    target_paths = ["$.target"] + [f"$.targets[{k}]" for k in range(len(scenario.targets))]
    seen_targets: dict[str, str] = {}
    for path, target in zip(target_paths, scenario.all_targets):
        problems += _check_target(target, path, size)
        if target.id in seen_targets:
            problems.append(f"{path}.id: duplicate target id {target.id!r} (also {seen_targets[target.id]})")
        seen_targets.setdefault(target.id, path)
    problems += check_estimator(scenario)
    if scenario.city.min_height_m > scenario.city.max_height_m:
        problems.append("$.city.min_height_m: greater than max_height_m")
    if scenario.city.kind == "geojson" and not scenario.city.geojson:
        problems.append("$.city.geojson: required when kind = 'geojson'")
    airframe = scenario.simulation.airframe
    if airframe.min_airspeed_mps >= airframe.max_airspeed_mps:
        problems.append("$.simulation.airframe.min_airspeed_mps: must be below max_airspeed_mps")
    for index, vehicle in enumerate(scenario.vehicles):
        if not airframe.min_airspeed_mps <= vehicle.speed_mps <= airframe.max_airspeed_mps:
            problems.append(f"$.vehicles[{index}].speed_mps: {vehicle.speed_mps} is outside the airframe's "
                            f"[{airframe.min_airspeed_mps}, {airframe.max_airspeed_mps}] m/s")
    for index, zone in enumerate(scenario.restricted):
        if zone.floor_m >= zone.ceiling_m:
            problems.append(f"$.restricted[{index}].floor_m: must be below ceiling_m")
    problems += check_planner(scenario.planner)
    problems += check_multitarget(scenario.multitarget, [scenario.sensor_for(v) for v in scenario.vehicles],
                                  scenario.planner.kind, scenario.city)
    if problems:
        raise ScenarioError("; ".join(problems))
    return scenario
