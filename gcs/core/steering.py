"""Steering a vehicle along its planned path through the autopilot's own course loop.

A plan is a turn rate ``u_j`` held over each step ``T`` (wang2012 eq. 1); the
path it gives (:class:`PlannedPath`) is what the vehicle should fly. An
autopilot does not take turn rates. ArduPlane takes a course
(``GUIDED_CHANGE_HEADING``) and turns toward it with a bank proportional to the
course error; PX4 takes a position setpoint and flies toward it. So the daemon
works out the turn rate the vehicle needs now and encodes it as the course that
makes the autopilot's loop turn at that rate.

**The course loop's model** (:class:`CourseLoop`, identified from step responses
by ``gcs-bench autopilots --identify``): small course errors ``e`` are closed at
``omega = K e`` through a first-order lag ``tau`` (bank dynamics),

.. math::
    \\tau \\dot\\omega = K e - \\omega, \\qquad \\dot\\chi = \\omega,
    \\qquad |\\omega| \\le \\omega_{max}.

ArduPlane's loop is a bank demand ``phi = k_p e`` (GUIDED_P, 5000 centidegrees a
radian) and a turn ``omega = eta g tan(phi) / V``, where ``eta`` (0.71 on SITL) is the
share of the coordinated turn the plane achieves at a bank, so ``K = eta g k_p / V``:
0.25 /s at 25 m/s, a 4 s time constant for a small step. Its largest turn rate is
set by the bank limit ``atan(a / g)`` that the lateral acceleration limit ``a`` of each
command gives: 0.177 rad/s under the daemon's commands at 0.2 rad/s, of which the
planner plans an ArduPlane at :data:`STEERING_HEADROOM` (:meth:`CourseLoop.flyable_turn_rate`).

**Path following** (:func:`follow`). From the point of the path nearest the
vehicle: its signed cross-track error ``d`` (left of the path positive), the
path's course ``chi_p`` there and its turn rate ``u`` one lag ``tau`` further on
(so the turn begins when the plan's does, not ``tau`` later). The desired course
turns toward the path over a look-ahead distance ``L``, and the wanted turn rate
is the plan's plus a correction toward it:

.. math::
    \\chi_d = \\chi_p - \\arctan(d / L), \\qquad
    \\omega_d = \\mathrm{clip}\\big(u + k_\\chi \\,\\mathrm{wrap}(\\chi_d - \\chi), \\pm\\omega_{max}\\big).

**The encoding with lead**: the course to command is the current one plus the
error that makes the loop turn at ``omega_d``, plus the turn made while the
command is held (half a steering period) and while the telemetry it was
computed from travelled (``latency``):

.. math::
    \\chi_{cmd} = \\chi + \\omega_d / K + \\omega_d (T_s / 2 + t_{lat}).

Commanding the plan's own course instead (no lead) turns at ``K e``, which for
the small course changes of a plan made every second is a fraction of the
planned rate: the 3 s lag and half turn rate seen on a real ArduPlane.
A position setpoint (PX4) goes far ahead along ``chi_cmd`` too: PX4 flies
toward it with its own course loop, so the same lead makes it turn at ``omega_d``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.kinematics import VehicleState, rollout

__all__ = ["CourseLoop", "COURSE_LOOPS", "IDENTIFIED_AT_TURN_RATE_RAD_S", "STEERING_HEADROOM", "PlannedPath", "Steering", "course_loop", "follow"]

IDENTIFIED_AT_TURN_RATE_RAD_S = 0.2
"""The configured turn-rate limit of the vehicle a course loop is identified on (the daemon sends its course steps
with the lateral acceleration limit ``margin V`` times it)."""
STEERING_HEADROOM = 0.9
"""A vehicle is planned at this share of the turn rate its autopilot reaches, so that the path follower can
turn harder than the plan to win back an error (a path planned at the very limit leaves it none: a vehicle
that falls outside a turn then stays outside, and one a little inside is asked for less than the plan)."""
SAMPLES_PER_STEP = 10
"""Points per plan step on a :class:`PlannedPath` (0.1 s apart with 1 s steps)."""
LOOKAHEAD_S = 4.0
"""``L / V``: the cross-track error is closed over about this much flight."""
COURSE_GAIN_PER_S = 0.8
"""``k_chi``: turn rate asked per radian of course error from the desired course, 1/s."""


@dataclass(frozen=True)
class CourseLoop:
    """An autopilot's course loop (module docstring): small-signal gain ``K`` (1/s), lag ``tau`` (s) and the
    turn rate it reaches in a large step (rad/s), at the airspeed it was identified at (m/s). A bank-to-turn
    loop (ArduPlane's: bank proportional to the error) has a gain that scales as ``1 / V``; a turn-rate loop's
    does not."""

    gain_per_s: float
    lag_s: float
    max_turn_rate_rad_s: float
    airspeed_mps: float
    bank_to_turn: bool

    def gain_at(self, airspeed_mps: float) -> float:
        """``K`` at another airspeed."""
        return self.gain_per_s * (self.airspeed_mps / max(airspeed_mps, 1.0) if self.bank_to_turn else 1.0)

    def flyable_turn_rate(self, configured_rad_s: float) -> float:
        """The turn-rate limit to plan a vehicle at whose airframe is configured for ``configured_rad_s``:
        :data:`STEERING_HEADROOM` of the rate this autopilot reaches under the daemon's commands. The lateral
        acceleration limit the daemon sends, and so the rate reached, scale with the configured limit; the
        loop was identified at :data:`IDENTIFIED_AT_TURN_RATE_RAD_S`."""
        reached = configured_rad_s * min(1.0, self.max_turn_rate_rad_s / IDENTIFIED_AT_TURN_RATE_RAD_S)
        return STEERING_HEADROOM * reached


COURSE_LOOPS: dict[str, CourseLoop] = {
    "ideal": CourseLoop(gain_per_s=0.991, lag_s=0.513, max_turn_rate_rad_s=0.2, airspeed_mps=25.0,
                        bank_to_turn=False),
    "arduplane": CourseLoop(gain_per_s=0.249, lag_s=0.208, max_turn_rate_rad_s=0.177, airspeed_mps=25.0,
                            bank_to_turn=True),
}
"""The course loops a vehicle is steered with, by the autopilot its scenario names, at 25 m/s. ``arduplane`` is
the real ArduPlane's, identified on ArduPilot's SITL by ``gcs-bench autopilots --identify --sitl`` (and
re-identified by its tests where SITL is at hand); ``ideal`` is the simulated ideal airframe's, as
``gcs-bench autopilots --identify`` measures it (benchmarks/tests identifies it again and compares;
tests/unit/test_steering.py holds both to their closed forms). ``px4`` flies toward its carrot with the
airframe's own course loop, ``ideal``'s, which an autopilot without an entry takes too."""


def course_loop(autopilot: str) -> CourseLoop:
    """The course loop of a named autopilot (``ideal``'s for a name without one)."""
    return COURSE_LOOPS.get(autopilot, COURSE_LOOPS["ideal"])


@dataclass(frozen=True)
class PlannedPath:
    """One vehicle's plan as a dense path: points (N, 2), courses (N,) and turn rates (N,) every ``spacing_s``
    seconds of flight from the plan's start, at the plan's altitude and airspeed."""

    points: NDArray[np.float64]
    courses: NDArray[np.float64]
    turn_rates: NDArray[np.float64]
    spacing_s: float
    altitude_m: float
    airspeed_mps: float

    @classmethod
    def from_plan(cls, start: VehicleState, turn_rates: NDArray[np.float64], step_s: float,
                  max_turn_rate: float) -> PlannedPath:
        """The path of a one-vehicle ``start`` flying ``turn_rates`` (H,), each held ``step_s`` (eq. 1)."""
        rates = np.clip(np.asarray(turn_rates, dtype=np.float64), -max_turn_rate, max_turn_rate)
        dense = np.repeat(rates, SAMPLES_PER_STEP)
        spacing = step_s / SAMPLES_PER_STEP
        xy, heading = rollout(start, dense[None, :], spacing, max_turn_rate)
        points = np.vstack([start.xy[:1], xy[0]])
        courses = np.concatenate([start.heading[:1], heading[0]])
        return cls(points, courses, np.append(dense, dense[-1]), spacing, float(start.altitude[0]),
                   float(start.speed[0]))

    def nearest(self, position_xy: NDArray[np.float64]) -> int:
        """Index of the path point nearest ``position_xy``."""
        offsets = self.points - np.asarray(position_xy, dtype=np.float64)[:2]
        return int(np.argmin(np.einsum("ij,ij->i", offsets, offsets)))

    def cross_track_m(self, index: int, position_xy: NDArray[np.float64]) -> float:
        """Signed distance of ``position_xy`` from the path at ``index``: positive to the left of its course."""
        dx, dy = np.asarray(position_xy, dtype=np.float64)[:2] - self.points[index]
        course = self.courses[index]
        return float(math.cos(course) * dy - math.sin(course) * dx)


@dataclass(frozen=True)
class Steering:
    """What :func:`follow` asks: the course to command (with lead), the desired course (for a carrot), the
    wanted turn rate, and the cross-track and course errors against the path (m, rad)."""

    command_course_rad: float
    desired_course_rad: float
    turn_rate_rad_s: float
    cross_track_m: float
    course_error_rad: float


def follow(path: PlannedPath, position_xy: NDArray[np.float64], course_rad: float, speed_mps: float,
           loop: CourseLoop, *, period_s: float, latency_s: float = 0.0) -> Steering:
    """The steering that flies ``path`` from ``position_xy`` on ``course_rad`` (module docstring).

    Past the path's end the vehicle follows its last course (straight on).
    """
    index = path.nearest(position_xy)
    along = path.courses[index]
    cross = path.cross_track_m(index, position_xy)
    if index == len(path.points) - 1:  # past the end: project on the straight line beyond it
        along = path.courses[-1]
    speed = max(speed_mps, 1.0)
    ahead = min(index + int(round(loop.lag_s / path.spacing_s)), len(path.turn_rates) - 1)
    planned_rate = float(path.turn_rates[ahead]) if index < len(path.points) - 1 else 0.0
    desired = wrap_angle(along - math.atan(cross / (LOOKAHEAD_S * speed)))
    limit = loop.max_turn_rate_rad_s
    rate = min(max(planned_rate + COURSE_GAIN_PER_S * wrap_angle(desired - course_rad), -limit), limit)
    gain = loop.gain_at(speed)
    command = wrap_angle(course_rad + rate / gain + rate * (0.5 * period_s + latency_s))
    return Steering(float(command), float(desired), float(rate), cross, float(wrap_angle(course_rad - along)))
