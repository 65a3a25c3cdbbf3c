"""An autopilot-driven fixed-wing: guidance, bank-to-turn response, airspeed and altitude hold.

This is the truth model behind every simulated vehicle. It is deliberately a
step richer than the planner's kinematics (wang2012 eq. 1, where a turn-rate
command takes effect at once), so that a plan meets an airframe that lags, as
it would in flight:

* **Guidance** turns the active :class:`Guidance` into a desired course
  ``chi_d`` (ENU, from east, counter-clockwise): a course or heading hold, a
  fly-to point (which becomes a loiter about it on arrival) or a loiter circle.
  The loiter law steers toward the circle's tangent with a correction that
  grows with the radial error ``e = d - R``:
  ``chi_d = beta + s (pi/2 + atan(k_l e / R))``, where ``beta`` is the bearing
  from the centre to the vehicle and ``s = +1`` counter-clockwise, ``-1``
  clockwise (ArduPlane's default).
* **Lateral loop**: the commanded turn rate is ``omega_c = omega_ff + k_chi wrap(chi_d - chi)``
  (``omega_ff = s v_g / R`` on a loiter circle, so that the circle needs no course error),
  capped at ``omega_max = min(eta_max, g tan(phi_max) / V)``; the bank command
  is the coordinated-turn bank ``phi_c = atan(omega_c V / g)``, and the bank
  follows it as a first-order lag, exactly discretised (an autopilot with its own
  lateral controller gives the bank demand ``phi_c`` itself, ``Guidance.roll_command_rad``):
  ``phi+ = phi_c + (phi - phi_c) exp(-dt / tau_phi)``. The heading then turns
  at ``psi_dot = g tan(phi) / V``.
* **Airspeed** follows its command with time constant ``tau_V``; **altitude**
  approaches its command at ``(h_c - h) / tau_h``, at most ``max_climb_rate``.
* **Wind**: the ground velocity is ``V (cos psi, sin psi) + w``; a course
  command controls the course over ground ``chi = atan2(v_g)``, a heading
  command the heading ``psi`` (ArduPlane's GUIDED_CHANGE_HEADING param1 0 / 1).

Within a step the heading turns at a constant rate, so the air-relative path is
an exact arc (chord ``V dt sinc``, as :mod:`gcs.core.kinematics`), plus the wind
drift ``w dt``. Pure: state in, new state out; no randomness (the airframe is
the truth, sensors add the noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import wrap_angle

__all__ = ["GRAVITY_MPS2", "Airframe", "AirframeState", "Guidance", "GuidanceKind", "LOITER_GAIN"]

GuidanceKind = Literal["course", "heading", "goto", "loiter", "parked"]
"""What a :class:`Guidance` flies (its docstring says how)."""

GRAVITY_MPS2 = 9.80665
LOITER_GAIN = 1.5
"""``k_l`` of the loiter law: how sharply a radial error turns the course toward the circle."""


@dataclass(frozen=True)
class Guidance:
    """What the autopilot is asked to do.

    Attributes
    ----------
    kind : ``"course"``, ``"heading"``, ``"goto"``, ``"loiter"`` or ``"parked"``
        ``course``: hold ``direction_rad`` over the ground; ``heading``: hold it
        through the air; ``goto``: fly to ``point_enu_m`` then loiter about it;
        ``loiter``: circle ``point_enu_m``; ``parked``: stand still on the ground.
    direction_rad : float
        ENU course or heading for ``course``/``heading``.
    point_enu_m : tuple of 2 float
        Fly-to point or loiter centre, ENU metres.
    radius_m : float
        Loiter radius (also the arrival distance of ``goto``).
    clockwise : bool
        Loiter direction (ArduPlane loiters clockwise unless told otherwise).
    altitude_m : float
        Commanded altitude, ENU up, metres.
    airspeed_mps : float
        Commanded airspeed, m/s.
    max_turn_rate_rad_s : float or None
        An extra turn-rate cap for this command (GUIDED_CHANGE_HEADING's lateral
        acceleration limit ``a`` gives ``a / V``); None for none.
    roll_command_rad : float or None
        A bank demand computed by the autopilot's own lateral controller (e.g.
        ArduPlane's guided heading PID); when set it replaces the lateral loop
        above (the bank still follows it with ``tau_phi``, capped at the bank
        limit), and ``direction_rad`` is only what that controller aims at.
    """

    kind: GuidanceKind
    altitude_m: float
    airspeed_mps: float
    direction_rad: float = 0.0
    point_enu_m: tuple[float, float] = (0.0, 0.0)
    radius_m: float = 150.0
    clockwise: bool = True
    max_turn_rate_rad_s: float | None = None
    roll_command_rad: float | None = None


@dataclass(frozen=True)
class AirframeState:
    """Truth state of one fixed-wing.

    ``position_enu_m`` (3,) is x east, y north and altitude (ENU up, metres
    above the scenario origin); ``heading_rad`` is air-relative (ENU);
    ``turn_rate_rad_s`` is the current heading rate; ``distance_m`` is the
    odometer over the ground (the INS's truth); ``elapsed_s`` the simulation time.
    """

    position_enu_m: NDArray[np.float64]
    heading_rad: float
    roll_rad: float
    airspeed_mps: float
    climb_rate_mps: float = 0.0
    turn_rate_rad_s: float = 0.0
    distance_m: float = 0.0
    elapsed_s: float = 0.0

    def ground_velocity(self, wind_enu_mps: tuple[float, float]) -> NDArray[np.float64]:
        """ENU ground velocity (3,), m/s (zero for a plane standing on the ground, airspeed 0)."""
        if self.airspeed_mps == 0.0:
            return np.zeros(3)
        return np.array([
            self.airspeed_mps * math.cos(self.heading_rad) + wind_enu_mps[0],
            self.airspeed_mps * math.sin(self.heading_rad) + wind_enu_mps[1],
            self.climb_rate_mps,
        ])

    def course_rad(self, wind_enu_mps: tuple[float, float]) -> float:
        """Course over the ground, ENU radians (the heading when the ground speed is zero)."""
        velocity = self.ground_velocity(wind_enu_mps)
        if math.hypot(velocity[0], velocity[1]) < 1e-9:
            return self.heading_rad
        return math.atan2(velocity[1], velocity[0])


@dataclass(frozen=True)
class Airframe:
    """The response of one vehicle type; see the module docstring for the laws.

    Parameters
    ----------
    config : AirframeConfig
        Bank limit, time constants, climb rate, airspeed band, default loiter radius.
    max_turn_rate_rad_s : float
        The vehicle's turn-rate limit ``eta_max`` (wang2012 eq. 1).
    wind_enu_mps : tuple of 2 float
        Constant wind, ENU m/s.
    """

    config: AirframeConfig
    max_turn_rate_rad_s: float
    wind_enu_mps: tuple[float, float] = (0.0, 0.0)

    def turn_rate_limit(self, airspeed_mps: float) -> float:
        """``min(eta_max, g tan(phi_max) / V)``, rad/s."""
        return min(self.max_turn_rate_rad_s, GRAVITY_MPS2 * math.tan(self.config.max_bank_rad) / airspeed_mps)

    def desired_direction(self, state: AirframeState, guidance: Guidance) -> tuple[float, bool, float]:
        """Desired direction (ENU radians), whether it is a heading (True) or a course (False),
        and the feedforward turn rate (rad/s: ``s v_g / R`` on a loiter circle, else 0)."""
        if guidance.kind == "heading":
            return guidance.direction_rad, True, 0.0
        if guidance.kind == "course":
            return guidance.direction_rad, False, 0.0
        dx = state.position_enu_m[0] - guidance.point_enu_m[0]
        dy = state.position_enu_m[1] - guidance.point_enu_m[1]
        distance = math.hypot(dx, dy)
        if guidance.kind == "goto" and distance > guidance.radius_m:
            return math.atan2(-dy, -dx), False, 0.0
        bearing = math.atan2(dy, dx)  # from the centre to the vehicle
        sign = -1.0 if guidance.clockwise else 1.0
        correction = math.atan(LOITER_GAIN * (distance - guidance.radius_m) / guidance.radius_m)
        ground = state.ground_velocity(self.wind_enu_mps)
        feedforward = sign * math.hypot(ground[0], ground[1]) / guidance.radius_m
        return bearing + sign * (0.5 * math.pi + correction), False, feedforward

    def step(self, state: AirframeState, guidance: Guidance, dt: float) -> AirframeState:
        """Advance ``dt`` seconds under ``guidance`` (``parked``: nothing moves)."""
        if guidance.kind == "parked":
            return replace(state, roll_rad=0.0, airspeed_mps=0.0, climb_rate_mps=0.0, turn_rate_rad_s=0.0,
                           elapsed_s=state.elapsed_s + dt)
        cfg = self.config
        wind = self.wind_enu_mps
        airspeed = state.airspeed_mps
        lateral_speed = max(airspeed, cfg.min_airspeed_mps)  # bank-to-turn at the speed of flight (a take-off starts at 0)
        if guidance.roll_command_rad is not None:
            roll_c = min(max(guidance.roll_command_rad, -cfg.max_bank_rad), cfg.max_bank_rad)
        else:
            direction, is_heading, feedforward = self.desired_direction(state, guidance)
            current = state.heading_rad if is_heading else state.course_rad(wind)
            limit = self.turn_rate_limit(lateral_speed)
            if guidance.max_turn_rate_rad_s is not None:
                limit = min(limit, guidance.max_turn_rate_rad_s)
            omega_c = min(max(feedforward + cfg.heading_gain_per_s * wrap_angle(direction - current), -limit), limit)
            roll_c = math.atan(omega_c * lateral_speed / GRAVITY_MPS2)
        roll = roll_c + (state.roll_rad - roll_c) * math.exp(-dt / cfg.roll_time_constant_s)
        turn_rate = GRAVITY_MPS2 * math.tan(roll) / lateral_speed
        turn_rate = min(max(turn_rate, -self.max_turn_rate_rad_s), self.max_turn_rate_rad_s)
        half = 0.5 * turn_rate * dt
        chord = airspeed * dt * (math.sin(half) / half if half != 0.0 else 1.0)
        mean_heading = state.heading_rad + half
        step_x = chord * math.cos(mean_heading) + wind[0] * dt
        step_y = chord * math.sin(mean_heading) + wind[1] * dt
        climb = (guidance.altitude_m - state.position_enu_m[2]) / cfg.altitude_time_constant_s
        climb = min(max(climb, -cfg.max_climb_rate_mps), cfg.max_climb_rate_mps)
        command = min(max(guidance.airspeed_mps, cfg.min_airspeed_mps), cfg.max_airspeed_mps)
        position = state.position_enu_m + np.array([step_x, step_y, climb * dt])
        if (guidance.altitude_m - state.position_enu_m[2]) * (guidance.altitude_m - position[2]) < 0.0:
            position[2] = guidance.altitude_m  # do not overshoot the commanded altitude
        return replace(
            state,
            position_enu_m=position,
            heading_rad=wrap_angle(state.heading_rad + turn_rate * dt),
            roll_rad=roll,
            airspeed_mps=command + (airspeed - command) * math.exp(-dt / cfg.airspeed_time_constant_s),
            climb_rate_mps=climb,
            turn_rate_rad_s=turn_rate,
            distance_m=state.distance_m + math.hypot(step_x, step_y),
            elapsed_s=state.elapsed_s + dt,
        )
