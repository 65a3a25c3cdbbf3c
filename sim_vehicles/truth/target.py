"""Ground-target truth models.

* :class:`WhiteNoiseTarget`: wang2012 section 5's target, a discretised
  white-noise-acceleration model (state x, y, vx, vy; per-step velocity noise of
  standard deviation ``sqrt(q T)``, 1.4 m/s at 1 s in the paper) with a speed
  limit. It stays on open ground: a step that would end inside a building or
  outside the city is replaced by a bounce (the velocity component that would
  cross is reversed), since a ground vehicle cannot drive through walls.
* :class:`StreetTarget`: drives along the street grid's centre lines at a
  cruising speed and picks a new direction at each intersection (straight on,
  left or right; never a U-turn unless it is a dead end at the city's edge).
* :class:`~sim_vehicles.truth.road_target.RoadTarget`: drives a road graph (a
  real city's streets, GeoJSON roads) the same way.

* :class:`ScriptedTarget`: follows a time-stamped path (``t_s,x_m,y_m`` CSV),
  linearly interpolated, holding the last point after the end.

All are pure: state in, ``numpy.random.Generator`` in, new state out; every
``step`` advances :attr:`TargetState.elapsed_s` by ``dt``. :func:`target_model`
and :func:`start_state` build the model and the initial state a scenario's
``[target]`` (or one of its ``[[targets]]``) table describes.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from gcs.config.world import resolve_path
from sim_vehicles.truth.road_target import RoadTarget
from sim_vehicles.truth.target_state import TargetState

if TYPE_CHECKING:
    from gcs.config import Scenario, TargetConfig
    from gcs.core.world import World

__all__ = ["TargetState", "WhiteNoiseTarget", "StreetTarget", "RoadTarget", "ScriptedTarget", "TargetModel",
           "target_model", "start_state", "CSV_HEADER"]

CSV_HEADER = ("t_s", "x_m", "y_m")
"""Columns of a scripted target's path file: time (s), ENU east and north (m)."""


@dataclass(frozen=True)
class WhiteNoiseTarget:
    """White-noise acceleration with a speed cap, bouncing off blocked ground.

    ``blocked(xy (..., 2)) -> bool (...)`` says where the target cannot be
    (inside buildings, outside the city).
    """

    accel_psd_m2_s3: float
    max_speed_mps: float
    blocked: Callable[[NDArray[np.float64]], NDArray[np.bool_]]

    def step(self, state: TargetState, dt: float, rng: np.random.Generator) -> TargetState:
        """Advance ``dt`` seconds: exact CWNA sample, speed cap, bounce off blocked ground."""
        q = self.accel_psd_m2_s3
        # Exact sample of the integrated white-noise acceleration over dt, per axis.
        cov = q * np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
        noise = rng.multivariate_normal(np.zeros(2), cov, size=2)  # rows: x, y; cols: position, velocity
        velocity = state.velocity + noise[:, 1]
        speed = float(np.hypot(*velocity))
        if speed > self.max_speed_mps:
            velocity = velocity * (self.max_speed_mps / speed)
        position = state.position + state.velocity * dt + noise[:, 0]
        if self.blocked(position[None])[0]:
            for axis in (0, 1):
                trial = state.position.copy()
                trial[axis] = position[axis]
                if self.blocked(trial[None])[0]:
                    velocity[axis] = -velocity[axis]
                    position[axis] = state.position[axis]
            if self.blocked(position[None])[0]:
                position = state.position.copy()
                velocity = -velocity
        return TargetState(position, velocity, state.elapsed_s + dt)


@dataclass(frozen=True)
class StreetTarget:
    """Drives the street grid (north-south streets at ``xs``, east-west at ``ys``)."""

    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    speed_mps: float = 10.0
    turn_probability: float = 0.5

    def start(self, near_xy: NDArray[np.float64], rng: np.random.Generator) -> TargetState:
        """Start at the intersection nearest ``near_xy``, heading along a random street."""
        position = np.array([self.xs[np.argmin(np.abs(self.xs - near_xy[0]))],
                             self.ys[np.argmin(np.abs(self.ys - near_xy[1]))]])
        direction = self._choose(position, None, rng)
        return TargetState(position, direction * self.speed_mps)

    def _choose(self, at: NDArray[np.float64], heading: NDArray[np.float64] | None,
                rng: np.random.Generator) -> NDArray[np.float64]:
        options = []
        for d in (np.array([1.0, 0.0]), np.array([-1.0, 0.0]), np.array([0.0, 1.0]), np.array([0.0, -1.0])):
            nxt = at + d
            inside = self.xs[0] <= nxt[0] <= self.xs[-1] and self.ys[0] <= nxt[1] <= self.ys[-1]
            u_turn = heading is not None and np.dot(d, heading) < -0.5
            if inside and not u_turn:
                options.append(d)
        if not options:  # dead end: turn back
            if heading is None:
                raise ValueError(f"the street grid has no street from {at.tolist()}: nowhere to drive")
            return -heading
        if heading is not None:
            straight = [d for d in options if np.dot(d, heading) > 0.5]
            if straight and rng.random() >= self.turn_probability:
                return straight[0]
        return options[rng.integers(len(options))]

    def step(self, state: TargetState, dt: float, rng: np.random.Generator) -> TargetState:
        """Drive ``dt`` seconds, turning at every intersection passed on the way."""
        position, heading = state.position.copy(), state.velocity / self.speed_mps
        remaining = self.speed_mps * dt
        while remaining > 1e-9:
            axis, lines = (0, self.xs) if abs(heading[0]) > 0.5 else (1, self.ys)
            sign = np.sign(heading[axis])
            ahead = lines[(lines - position[axis]) * sign > 1e-9]
            if ahead.size == 0:
                heading = self._choose(position, heading, rng)
                continue
            gap = float(np.min(np.abs(ahead - position[axis])))
            if gap > remaining:
                position[axis] += sign * remaining
                break
            position[axis] += sign * gap
            remaining -= gap
            heading = self._choose(position, heading, rng)
        return TargetState(position, heading * self.speed_mps, state.elapsed_s + dt)


@dataclass(frozen=True, eq=False)
class ScriptedTarget:
    """Follows a time-stamped path: ``times_s`` (N,) strictly increasing, ``xy`` (N, 2) ENU metres.

    The path's times are the scenario's (seconds since the start): at elapsed
    time ``t`` the target is at the linear interpolation of the path, with the
    slope of the segment containing ``t`` as its velocity (the later segment at
    a vertex). Before the first time it waits at the first point and after the
    last it holds the last point, both with zero velocity. The path is the
    whole truth: ``step`` draws no random numbers.
    """

    times_s: NDArray[np.float64]
    xy: NDArray[np.float64]

    def __post_init__(self) -> None:
        times = np.array(self.times_s, dtype=np.float64)
        xy = np.array(self.xy, dtype=np.float64)
        if times.ndim != 1 or len(times) == 0 or xy.shape != (len(times), 2):
            raise ValueError(f"a scripted path needs times (N,) and xy (N, 2) with N >= 1, got {times.shape} and {xy.shape}")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(xy))):
            raise ValueError("a scripted path must be finite")
        if np.any(np.diff(times) <= 0.0):
            raise ValueError("a scripted path's times must be strictly increasing")
        object.__setattr__(self, "times_s", times)
        object.__setattr__(self, "xy", xy)

    @classmethod
    def from_csv(cls, path: str | Path) -> ScriptedTarget:
        """Read a path file: header ``t_s,x_m,y_m``, then one row per point (blank lines skipped).

        Raises
        ------
        ValueError
            Naming the file (and the line, 1-based): unreadable file, wrong
            header, wrong column count, a value that is not a finite number,
            times not strictly increasing, or no points.
        """
        path = Path(path)
        times: list[float] = []
        points: list[tuple[float, float]] = []
        try:
            with path.open(newline="", encoding="utf-8") as handle:
                reader = csv.reader(handle)
                header = None
                for row in reader:
                    cells = [cell.strip() for cell in row]
                    if not any(cells):
                        continue
                    where = f"{path}:{reader.line_num}"
                    if header is None:
                        header = tuple(cells)
                        if header != CSV_HEADER:
                            raise ValueError(f"{where}: header must be {','.join(CSV_HEADER)}, got {','.join(cells)}")
                        continue
                    t, x, y = _csv_row(cells, where)
                    if times and t <= times[-1]:
                        raise ValueError(f"{where}: t_s = {t} is not after the previous row's {times[-1]}")
                    times.append(t)
                    points.append((x, y))
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path}: cannot read the target path: {exc}") from None
        if not times:
            raise ValueError(f"{path}: no points (expected the header {','.join(CSV_HEADER)} and at least one row)")
        return cls(np.array(times), np.array(points))

    def position_at(self, t_s: float) -> NDArray[np.float64]:
        """Interpolated position (2,) at elapsed time ``t_s``, held before the start and after the end."""
        return np.array([np.interp(t_s, self.times_s, self.xy[:, 0]), np.interp(t_s, self.times_s, self.xy[:, 1])])

    def velocity_at(self, t_s: float) -> NDArray[np.float64]:
        """Slope (2,) of the segment containing ``t_s``; zero before the start and from the last point on."""
        i = int(np.searchsorted(self.times_s, t_s, side="right")) - 1
        if 0 <= i < len(self.times_s) - 1:
            return (self.xy[i + 1] - self.xy[i]) / (self.times_s[i + 1] - self.times_s[i])
        return np.zeros(2)

    def start(self, rng: np.random.Generator | None = None) -> TargetState:
        """The target at elapsed time 0 (the first point when the path starts at or after 0)."""
        return TargetState(self.position_at(0.0), self.velocity_at(0.0), 0.0)

    def step(self, state: TargetState, dt: float, rng: np.random.Generator | None = None) -> TargetState:
        """The target ``dt`` seconds after ``state`` (interpolated at ``state.elapsed_s + dt``)."""
        t = state.elapsed_s + dt
        return TargetState(self.position_at(t), self.velocity_at(t), t)


def _csv_row(cells: list[str], where: str) -> tuple[float, float, float]:
    if len(cells) != len(CSV_HEADER):
        raise ValueError(f"{where}: expected {len(CSV_HEADER)} values ({','.join(CSV_HEADER)}), got {len(cells)}")
    values = []
    for name, cell in zip(CSV_HEADER, cells):
        try:
            value = float(cell)
        except ValueError:
            raise ValueError(f"{where}: {name} = {cell!r} is not a number") from None
        if not math.isfinite(value):
            raise ValueError(f"{where}: {name} = {cell!r} is not finite")
        values.append(value)
    return values[0], values[1], values[2]


TargetModel = WhiteNoiseTarget | StreetTarget | RoadTarget | ScriptedTarget
"""Any ground-target truth model: ``step(state, dt, rng) -> TargetState``."""


def target_model(scenario: Scenario, world: World, motion: str | None = None,
                 base_dir: Path | None = None, target: TargetConfig | None = None) -> TargetModel:
    """The truth model of ``target`` (default ``scenario.target``; ``motion`` overrides its ``motion``).

    * ``white_noise_acceleration``: :class:`WhiteNoiseTarget`, blocked outside the
      world's extent (``world.bounds_m``) and inside buildings;
    * ``streets``: at ``min(street_speed_mps, max_speed_mps)``, turning with ``turn_probability``:
      :class:`StreetTarget` on a generated city's street grid, or :class:`RoadTarget` on the world's
      road graph when the city declares its roads (``[city] roads_geojson``) or has no grid;
    * ``scripted``: :class:`ScriptedTarget` from the inline ``target.path``, or from
      ``target.path_file``, relative to ``base_dir`` (the current directory when None)
      unless absolute.

    Raises
    ------
    ValueError
        Unknown motion, no roads to drive, no ``path_file``, or a bad path file.
    """
    cfg = scenario.target if target is None else target
    motion = motion or cfg.motion
    if motion == "white_noise_acceleration":
        def blocked(xy: NDArray[np.float64]) -> NDArray[np.bool_]:
            return ~world.inside(xy) | world.buildings.contains_xy(xy)

        return WhiteNoiseTarget(cfg.accel_psd_m2_s3, cfg.max_speed_mps, blocked)
    if motion == "streets":
        speed = min(cfg.street_speed_mps, cfg.max_speed_mps)
        if world.streets is not None and not scenario.city.roads_geojson:
            return StreetTarget(world.streets.xs, world.streets.ys, speed_mps=speed,
                                turn_probability=cfg.turn_probability)
        if world.roads is None:
            raise ValueError("motion = 'streets' needs roads to drive: a generated city or [city] roads_geojson")
        return RoadTarget(world.roads, speed_mps=speed, turn_probability=cfg.turn_probability)
    if motion == "scripted":
        if cfg.path:
            rows = np.array(cfg.path, dtype=np.float64)
            return ScriptedTarget(rows[:, 0], rows[:, 1:3])
        if not cfg.path_file:
            raise ValueError("$.target.path_file: required when motion = 'scripted'")
        return ScriptedTarget.from_csv(resolve_path(cfg.path_file, base_dir))
    raise ValueError(f"unknown target motion {motion!r}; expected white_noise_acceleration, streets or scripted")


def start_state(model: TargetModel, scenario: Scenario, rng: np.random.Generator,
                target: TargetConfig | None = None) -> TargetState:
    """The state at time 0 of ``target`` (default ``scenario.target``).

    :class:`StreetTarget`: the street crossing nearest ``target.start_enu_m``, on a
    random street (draws from ``rng``); :class:`RoadTarget`: the road point nearest it,
    either way along a two-way road (draws from ``rng``); :class:`ScriptedTarget`: the path at time
    0; otherwise ``target.start_enu_m`` moving at ``target.start_velocity_mps``.
    """
    cfg = scenario.target if target is None else target
    start = np.asarray(cfg.start_enu_m, dtype=np.float64)
    if isinstance(model, (StreetTarget, RoadTarget)):
        return model.start(start, rng)
    if isinstance(model, ScriptedTarget):
        return model.start()
    return TargetState(start, np.asarray(cfg.start_velocity_mps, dtype=np.float64))
