"""How closely a vehicle flies its plan: course error against the planned path and the turn rate it achieves.

Both the personalities' closed loop (:func:`benchmarks.autopilots.fly`) and the real ArduPlane's
(:mod:`benchmarks.sitl.flight`) take a :class:`SteeringSample` per vehicle at every steering instant
(4 a second) once the plan has settled: the vehicle's course over the ground, its course error against
the planned path (the path's course at the point nearest the vehicle), and the turn rate the plan asks
for there. The figures are computed alike for both:

* **course error**: median, 90th percentile and maximum of ``|chi - chi_path|``, pooled over the vehicles;
* **turn rate achieved against planned**, where the plan asks for the vehicle's turn-rate limit
  ``omega_max``: at each instant ``i`` whose planned rate and that of the instant :data:`WINDOW_S` before it
  are both at the limit (``|u| >= 0.99 omega_max``) with the same sign, the course change over that window
  divided by its length, signed toward the planned turn. Its median over such instants, divided by
  ``omega_max``, is the share of the planned rate that the vehicle achieves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gcs.core.geometry import wrap_angle

__all__ = ["SteeringSample", "WINDOW_S", "course_following", "saturated_turn_rates"]

WINDOW_S = 1.0
"""The course change that gives the achieved turn rate is taken over this many seconds."""
AT_LIMIT = 0.99
"""A planned rate at least this share of the limit asks for the limit."""


@dataclass(frozen=True)
class SteeringSample:
    """One vehicle at one steering instant (module docstring); time in seconds of the vehicle's clock."""

    time_s: float
    course_rad: float
    course_error_rad: float
    planned_rate_rad_s: float


def saturated_turn_rates(samples: Sequence[SteeringSample], max_turn_rate_rad_s: float) -> list[float]:
    """The achieved turn rates (rad/s, toward the planned turn) at the instants that ask for the limit held over
    :data:`WINDOW_S` (module docstring)."""
    out: list[float] = []
    times = np.array([s.time_s for s in samples])
    limit = AT_LIMIT * max_turn_rate_rad_s
    for i, sample in enumerate(samples):
        j = int(np.searchsorted(times, sample.time_s - WINDOW_S + 1e-6)) - 1
        if j < 0 or sample.time_s - times[j] > 1.5 * WINDOW_S:
            continue
        before = samples[j]
        if abs(sample.planned_rate_rad_s) < limit or sample.planned_rate_rad_s * before.planned_rate_rad_s <= 0.0 \
                or abs(before.planned_rate_rad_s) < limit:
            continue
        rate = wrap_angle(sample.course_rad - before.course_rad) / (sample.time_s - before.time_s)
        out.append(math.copysign(1.0, sample.planned_rate_rad_s) * rate)
    return out


def course_following(per_vehicle: Sequence[Sequence[SteeringSample]], max_turn_rate_rad_s: float) -> dict:
    """The figures of the module docstring, pooled over the vehicles: ``course_error_deg_{median,p90,max}``,
    ``saturated_share`` (of the instants), ``turn_rate_planned_deg_s``, ``turn_rate_achieved_deg_s_{median,p90}``
    and ``turn_rate_ratio`` (NaN where there are none)."""
    errors = np.abs([s.course_error_rad for samples in per_vehicle for s in samples])
    turns = np.array([r for samples in per_vehicle for r in saturated_turn_rates(samples, max_turn_rate_rad_s)])
    count = sum(len(samples) for samples in per_vehicle)
    nan = float("nan")
    return {
        "course_error_deg_median": float(np.degrees(np.median(errors))) if errors.size else nan,
        "course_error_deg_p90": float(np.degrees(np.percentile(errors, 90))) if errors.size else nan,
        "course_error_deg_max": float(np.degrees(errors.max())) if errors.size else nan,
        "saturated_share": turns.size / count if count else nan,
        "turn_rate_planned_deg_s": math.degrees(max_turn_rate_rad_s),
        "turn_rate_achieved_deg_s_median": float(np.degrees(np.median(turns))) if turns.size else nan,
        "turn_rate_achieved_deg_s_p90": float(np.degrees(np.percentile(turns, 90))) if turns.size else nan,
        "turn_rate_ratio": float(np.median(turns) / max_turn_rate_rad_s) if turns.size else nan,
    }
