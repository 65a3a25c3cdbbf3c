"""Restricted airspace as a hard constraint on any plan, and the fallback that keeps a planner out of it.

wang2012 charges ``W_res`` for each planned position inside restricted airspace
(eq. 25-26), a penalty a plan may still pay. The guard makes it a constraint:

* **Margin.** A plan is sampled at its step ends, ``v T`` apart; every point of
  an arc between two samples lies within ``v T / 2`` of one of them, and the
  airframe flies a little off its plan. A sample closer than ``margin_m`` to a
  zone's outline (or inside it) is a violation; ``margin_m >= v T / 2`` makes
  the whole arc clear of the zone.
* **A way out after the horizon.** A plan that ends heading into a zone closer
  than a turn radius cannot avoid it afterwards. So the end state must have a
  clear loiter circle: one of the two circles of radius ``v / eta`` tangent to
  its heading misses every zone by the margin (it holds no zone vertex
  farther than ``r - margin`` and is at least ``r + margin`` away, or holds the
  zone whole). Flying that circle is always possible, so the previous plan
  shifted by a step, with a full-rate turn toward its clear circle appended,
  stays feasible: a feasible plan always exists once one did.

:meth:`AirspaceGuard.violations` counts both (one per sample too close, one for
no clear circle); :meth:`AirspaceGuard.safe` replaces each vehicle's plan that
has any by the primitive (:mod:`gcs.core.planners.primitives`) with the
fewest, nearest to the plan's first command. Every planner's plan passes
through it (:func:`gcs.core.tracker.plan`), the baselines' included.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.kinematics import VehicleState, rollout
from gcs.core.planners.primitives import primitives
from gcs.core.world.airspace import RestrictedAirspace

__all__ = ["AirspaceGuard", "shift_into_circle"]


@dataclass(frozen=True, eq=False)
class AirspaceGuard:
    """Hard restricted-airspace constraint; ``airspace`` empty (the default): nothing is restricted."""

    airspace: RestrictedAirspace = field(default_factory=RestrictedAirspace.empty)
    margin_m: float = 25.0

    @property
    def active(self) -> bool:
        return len(self.airspace) > 0

    def violations(self, xy: NDArray[np.float64], end_heading: NDArray[np.float64], altitude_m: float,
                   speed_mps: float, eta: float) -> NDArray[np.int64]:
        """Violations (C,) of paths ``xy`` (C, T, 2) ending at headings (C,), for one vehicle."""
        count = np.zeros(xy.shape[0], dtype=np.int64)
        if not self.active or not self.airspace.active(altitude_m).any():
            return count
        near = self.airspace.distances_xy(xy, altitude_m, self.margin_m) <= self.margin_m  # (C, T, S')
        count += near.any(axis=-1).sum(axis=-1)
        return count + ~self.clear_circle(xy[:, -1], end_heading, altitude_m, speed_mps / eta)

    def clear_circle(self, xy: NDArray[np.float64], heading: NDArray[np.float64], altitude_m: float,
                     radius_m: float) -> NDArray[np.bool_]:
        """Whether either loiter circle (radius ``radius_m``) tangent at positions (C, 2) and headings (C,) is clear."""
        left = np.stack([-np.sin(heading), np.cos(heading)], axis=-1) * radius_m
        centres = np.stack([xy + left, xy - left], axis=1)  # (C, 2, 2)
        reach = radius_m + self.margin_m
        nearest = self.airspace.distances_xy(centres, altitude_m, reach)  # (C, 2, S')
        clear = nearest >= reach
        if not clear.all():  # a circle near a zone is still clear if it holds the zone whole
            clear |= self.airspace.farthest_xy(centres, altitude_m) <= radius_m - self.margin_m
        either_clear: NDArray[np.bool_] = np.any(np.all(clear, axis=-1), axis=-1)
        return either_clear

    def plan_violations(self, vehicles: VehicleState, controls: NDArray[np.float64], step_s: float,
                        max_turn_rate: NDArray[np.float64]) -> NDArray[np.int64]:
        """Violations (..., V) of each vehicle's row of team plans (..., V, T)."""
        plans = np.asarray(controls, dtype=np.float64)
        counts = np.zeros(plans.shape[:-1], dtype=np.int64)
        if not self.active:
            return counts
        for i in range(len(vehicles)):
            counts[..., i] = self._row_violations(vehicles, i, plans[..., i, :], step_s, float(max_turn_rate[i]))
        return counts

    def _row_violations(self, vehicles: VehicleState, i: int, rows: NDArray[np.float64], step_s: float,
                        eta: float) -> NDArray[np.int64]:
        """Violations (...,) of vehicle ``i`` flying each of ``rows`` (..., T)."""
        flat = rows.reshape(-1, rows.shape[-1])
        xy, heading = rollout(vehicles.subset(i), flat[:, None, :], step_s, eta)
        count = self.violations(xy[:, 0], heading[:, 0, -1], float(vehicles.altitude[i]), float(vehicles.speed[i]), eta)
        return count.reshape(rows.shape[:-1])

    def safe(self, vehicles: VehicleState, controls: NDArray[np.float64], step_s: float,
             max_turn_rate: NDArray[np.float64]) -> NDArray[np.float64]:
        """Team plans (..., V, T) with each violating row replaced by the best primitive (module docstring);
        ``controls`` itself when no row violates."""
        if not self.active:
            return controls
        plans = np.asarray(controls, dtype=np.float64)
        bad = self.plan_violations(vehicles, plans, step_s, max_turn_rate) > 0
        if not bad.any():
            return controls
        out = plans.reshape((-1,) + plans.shape[-2:]).copy()
        bad = bad.reshape(out.shape[:2])
        for i in np.flatnonzero(bad.any(axis=0)).tolist():
            eta = float(max_turn_rate[i])
            library = primitives(eta, plans.shape[-1])
            count = self._row_violations(vehicles, i, library, step_s, eta)
            for k in np.flatnonzero(bad[:, i]):
                row = out[k, i]
                nearness = np.abs(library[:, 0] - row[0]) + 1e-3 * np.abs(library - row).sum(axis=1)
                out[k, i] = library[np.lexsort((nearness, count))[0]]
        safe_plans: NDArray[np.float64] = out.reshape(plans.shape)
        return safe_plans


def shift_into_circle(controls: NDArray[np.float64], eta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """The previous plan (V, T) moved one step on, its last step a full-rate left or right turn: two plans.

    One of them keeps a plan that had a clear loiter circle feasible (module docstring).
    """
    body = controls[:, 1:]
    return tuple(np.concatenate([body, sign * eta[:, None]], axis=1) for sign in (1.0, -1.0))
