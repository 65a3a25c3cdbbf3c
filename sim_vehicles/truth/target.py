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

Both are pure: state in, ``numpy.random.Generator`` in, new state out.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["TargetState", "WhiteNoiseTarget", "StreetTarget"]


@dataclass(frozen=True)
class TargetState:
    """Ground-truth target: ENU position (2,) and velocity (2,)."""

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]

    @property
    def vector(self) -> NDArray[np.float64]:
        """``[x, y, vx, vy]``."""
        return np.concatenate([self.position, self.velocity])


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
        return TargetState(position, velocity)


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
        return TargetState(position, heading * self.speed_mps)
