"""ArduPlane's guided heading controller: a PID from heading error to bank demand, bank limited by param3.

What ArduPlane does with a GUIDED_CHANGE_HEADING in force (``ArduPlane/mode_guided.cpp``,
``ModeGuided::update``, built with ``AP_PLANE_OFFBOARD_GUIDED_SLEW_ENABLED``):

* the error is ``wrap_PI(target - yaw)`` for a heading (param1 1) or
  ``wrap_PI(target - course over ground)`` for a course (param1 0), radians;
* the bank limit is ``min(degrees(atan(a / g)) * 100, roll_limit_cd)``
  centidegrees, where ``a = max(param3, 0.05)`` m/s^2 (``GCS_Mavlink.cpp``,
  ``handle_command_int_guided_slew_commands``) and ``roll_limit_cd`` is
  ROLL_LIMIT_DEG; at a = 5 m/s^2 that is 27 degrees;
* the bank demand ``nav_roll_cd`` is ``g2.guidedHeading.update_error(error, dt,
  limited)`` constrained to that limit; ``limited`` (the last output was at the
  limit) stops the integrator from growing (``AC_PID::update_i``).

The PID is ``AC_PID`` (``libraries/AC_PID/AC_PID.cpp``) with ArduPlane's
defaults (``ArduPlane/Parameters.h``: ``guidedHeading{5000, 0, 0, 0, 10, 5, 5,
5, 0}``), i.e. GUIDED_P = 5000 centidegrees of bank per radian of error,
GUIDED_I = GUIDED_D = GUIDED_FF = 0, GUIDED_IMAX = 10, GUIDED_FLTE = GUIDED_FLTD
= 5 Hz. ``update_error`` low-passes the error, ``e += alpha (error - e)`` with
``alpha = dt / (dt + 1 / (2 pi f_E))`` (``calc_lowpass_alpha_dt``), the first
sample after a reset taken as is; the output is ``kp e + I + kd de/dt``, the
integrator ``I += ki e dt`` clamped to IMAX.

So the turn follows the heading error: with a bank ``phi = kp e`` (below the
limit) a coordinated turn ``psi_dot = g tan(phi) / V`` closes the error like a
first-order lag of time constant ``V / (g kp_rad)`` (2.9 s at 25 m/s with
kp = 0.873 rad/rad), and a large error turns at the bank limit,
``g tan(phi_max) / V`` (0.2 rad/s at 5 m/s^2 and 25 m/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["GuidedHeadingPid", "GUIDED_P_DEFAULT", "bank_limit_cd"]

GUIDED_P_DEFAULT = 5000.0
"""GUIDED_P, centidegrees of bank demand per radian of heading error (ArduPlane/Parameters.h)."""
MIN_ACCEL_LIMIT_MPS2 = 0.05
"""GUIDED_CHANGE_HEADING's param3 is raised to at least this (``MAX(packet.param3, 0.05f)``)."""
GRAVITY_MSS = 9.80665


def bank_limit_cd(accel_limit_mps2: float, roll_limit_deg: float) -> float:
    """``min(degrees(atan(max(a, 0.05) / g)) * 100, ROLL_LIMIT_DEG * 100)``, centidegrees."""
    accel = max(accel_limit_mps2, MIN_ACCEL_LIMIT_MPS2)
    return min(math.degrees(math.atan(accel / GRAVITY_MSS)) * 100.0, roll_limit_deg * 100.0)


def _lowpass_alpha(dt: float, cutoff_hz: float) -> float:
    if cutoff_hz <= 0.0 or dt <= 0.0:
        return 1.0
    return dt / (dt + 1.0 / (2.0 * math.pi * cutoff_hz))


@dataclass
class GuidedHeadingPid:
    """``g2.guidedHeading``: gains as the GUIDED_* parameters; state is the filtered error, its derivative
    and the integrator (all in AC_PID's units: radians in, centidegrees out)."""

    kp: float = GUIDED_P_DEFAULT
    ki: float = 0.0
    kd: float = 0.0
    imax: float = 10.0
    filt_e_hz: float = 5.0
    filt_d_hz: float = 5.0
    error: float = 0.0
    derivative: float = 0.0
    integrator: float = 0.0
    needs_reset: bool = True

    def reset(self) -> None:
        """Forget the filter state (the next error is taken as is) and the integrator."""
        self.needs_reset = True
        self.integrator = 0.0

    def reset_i(self) -> None:
        """``reset_I``: zero the integrator (a new heading command does this)."""
        self.integrator = 0.0

    def update_error(self, error_rad: float, dt: float, limited: bool) -> float:
        """One ``update_error(error, dt, limit)``: the bank demand in centidegrees."""
        if not math.isfinite(error_rad):
            return 0.0
        if self.needs_reset:
            self.needs_reset = False
            self.error, self.derivative = error_rad, 0.0
        else:
            last = self.error
            self.error += _lowpass_alpha(dt, self.filt_e_hz) * (error_rad - self.error)
            if dt > 0.0:
                self.derivative += _lowpass_alpha(dt, self.filt_d_hz) * ((self.error - last) / dt - self.derivative)
        if self.ki != 0.0 and dt > 0.0:
            shrinking = (self.integrator > 0 > self.error) or (self.integrator < 0 < self.error)
            if not limited or shrinking:
                self.integrator = min(max(self.integrator + self.error * self.ki * dt, -self.imax), self.imax)
        else:
            self.integrator = 0.0
        return self.kp * self.error + self.integrator + self.kd * self.derivative
