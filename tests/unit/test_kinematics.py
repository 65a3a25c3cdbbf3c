"""UAV kinematics (wang2012 eq. 1): exact arcs checked against fine Euler integration."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.core.kinematics import VehicleState, rollout, step_vehicles


def _state(n: int = 1) -> VehicleState:
    return VehicleState(np.tile([100.0, 200.0], (n, 1)), np.full(n, 0.3), np.full(n, 25.0), np.full(n, 200.0))


@given(st.floats(-0.2, 0.2), st.floats(0.1, 3.0))
def test_arc_step_matches_fine_euler_integration(u: float, dt: float) -> None:
    xy, heading = rollout(_state(), np.array([[u]]), dt, 0.2)
    x, y, psi = 100.0, 200.0, 0.3
    n = 20000
    for _ in range(n):
        x += 25.0 * math.cos(psi) * dt / n
        y += 25.0 * math.sin(psi) * dt / n
        psi += u * dt / n
    np.testing.assert_allclose(xy[0, 0], [x, y], atol=2e-3)
    assert heading[0, 0] == pytest.approx(math.remainder(psi, 2 * math.pi), abs=1e-9)


def test_turn_rate_is_clipped_and_full_circle_closes() -> None:
    # 0.2 rad/s for 2 pi / 0.2 seconds is one full circle of radius v / u = 125 m.
    steps = 100
    dt = 2 * math.pi / 0.2 / steps
    xy, _ = rollout(_state(), np.full((1, steps), 5.0), dt, 0.2)  # 5 rad/s is clipped to 0.2
    np.testing.assert_allclose(xy[0, -1], [100.0, 200.0], atol=1e-6)
    centre = np.array([100.0, 200.0]) + 125.0 * np.array([-math.sin(0.3), math.cos(0.3)])
    np.testing.assert_allclose(np.linalg.norm(xy[0] - centre, axis=-1), 125.0, rtol=1e-9)


def test_population_rollout_equals_one_by_one() -> None:
    rng = np.random.default_rng(4)
    state = VehicleState(rng.uniform(0, 3000, (3, 2)), rng.uniform(-3, 3, 3), np.array([25.0, 22.0, 28.0]),
                         np.array([200.0, 210.0, 220.0]))
    controls = rng.uniform(-0.2, 0.2, size=(7, 3, 5))
    xy, heading = rollout(state, controls, 1.0, np.array([0.2, 0.15, 0.2]))
    for p in range(7):
        current = state
        for k in range(5):
            current = step_vehicles(current, controls[p, :, k], 1.0, np.array([0.2, 0.15, 0.2]))
            np.testing.assert_allclose(xy[p, :, k], current.xy, rtol=1e-12)
            np.testing.assert_allclose(heading[p, :, k], current.heading, atol=1e-12)
    assert xy.shape == (7, 3, 5, 2) and heading.shape == (7, 3, 5)
