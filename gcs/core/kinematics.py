"""Fixed-wing UAV kinematics of wang2012 eq. (1), rolled out for whole populations.

At constant speed ``v`` and altitude, with heading ``psi`` (ENU, from east,
counter-clockwise) and a turn-rate command ``u`` bounded by ``|u| <= eta_max``
(eq. 1 with ``u^steer eta_max = u``; the paper fixes ``u^accel = 0``):

.. math::
    \\dot x = v \\cos\\psi, \\quad \\dot y = v \\sin\\psi, \\quad \\dot\\psi = u

A command is held over a step of ``T`` seconds, so each step is an exact
circular arc, whose chord has length ``v T sinc(u T / 2)`` along the mean
heading ``psi + u T / 2``:

.. math::
    (x^+, y^+) = (x, y) + v T \\,\\frac{\\sin(uT/2)}{uT/2}
        \\big(\\cos(\\psi + uT/2), \\sin(\\psi + uT/2)\\big), \\quad
    \\psi^+ = \\psi + uT

(equal to ``x + (v/u)(sin psi+ - sin psi)``, and to the straight line when
``u = 0``, with no special case). Everything is vectorised over leading axes: a GA population
x vehicles x horizon is one call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle

__all__ = ["VehicleState", "rollout", "step_vehicles"]


@dataclass(frozen=True)
class VehicleState:
    """Planar states of V vehicles: ENU position (V, 2), heading (V,), speed (V,), altitude (V,)."""

    xy: NDArray[np.float64]
    heading: NDArray[np.float64]
    speed: NDArray[np.float64]
    altitude: NDArray[np.float64]

    @property
    def xyz(self) -> NDArray[np.float64]:
        """ENU positions (V, 3)."""
        return np.column_stack([self.xy, self.altitude])

    def __len__(self) -> int:
        return len(self.heading)

    def subset(self, index: int) -> VehicleState:
        """Vehicle ``index`` alone, as a team of one."""
        s = slice(index, index + 1)
        return VehicleState(self.xy[s], self.heading[s], self.speed[s], self.altitude[s])


@overload
def rollout(state: VehicleState, turn_rates: NDArray[np.float64], dt: float,
            max_turn_rate: NDArray[np.float64] | float,
            headings: Literal[True] = True) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
@overload
def rollout(state: VehicleState, turn_rates: NDArray[np.float64], dt: float,
            max_turn_rate: NDArray[np.float64] | float,
            headings: Literal[False]) -> tuple[NDArray[np.float64], None]: ...


def rollout(
    state: VehicleState,
    turn_rates: NDArray[np.float64],
    dt: float,
    max_turn_rate: NDArray[np.float64] | float,
    headings: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Positions and headings after each of T held turn-rate commands.

    Parameters
    ----------
    state : VehicleState
        V vehicles now.
    turn_rates : ndarray, shape (..., V, T)
        Commanded turn rates, rad/s (leading axes: e.g. a GA population).
        Clipped to ``+-max_turn_rate`` (eq. 27's bound).
    dt : float
        Step length, seconds.
    max_turn_rate : float or ndarray (V,)
        ``eta_max`` per vehicle, rad/s.
    headings : bool
        Also return the headings (planners that need only positions skip them).

    Returns
    -------
    xy : ndarray, shape (..., V, T, 2)
        ENU positions at the end of steps 1..T.
    heading : ndarray, shape (..., V, T), or None
        Headings at the end of steps 1..T, wrapped to (-pi, pi].
    """
    limit = np.asarray(max_turn_rate, dtype=np.float64)
    if limit.ndim:
        limit = limit[:, None]
    turn = np.minimum(np.maximum(turn_rates, -limit), limit) * dt
    psi_end = np.cumsum(turn, axis=-1)
    psi_end += state.heading[:, None]  # (..., V, T)
    half = 0.5 * turn
    # Each arc's chord as a complex number: length v T sinc(u T / 2) along psi + u T / 2
    # (np.sinc(x) = sin(pi x) / (pi x)); positions are the running sums of the chords.
    chord = np.sinc(half / np.pi) * (state.speed[:, None] * dt)
    chords = chord * np.exp(1j * (psi_end - half))
    xy: NDArray[np.float64] = np.cumsum(chords, axis=-1).view(np.float64).reshape(chords.shape + (2,))
    return xy + state.xy[:, None, :], (wrap_angle(psi_end) if headings else None)


def step_vehicles(state: VehicleState, turn_rates: NDArray[np.float64], dt: float,
                  max_turn_rate: NDArray[np.float64] | float) -> VehicleState:
    """Fly every vehicle one step with its turn-rate command (V,)."""
    xy, heading = rollout(state, np.asarray(turn_rates, dtype=np.float64)[:, None], dt, max_turn_rate)
    return VehicleState(xy[:, 0], heading[:, 0], state.speed, state.altitude)
