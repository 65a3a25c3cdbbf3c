"""Target motion models (wang2012 eq. 2): discretisation checked by its own algebra."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.core.models.motion import constant_acceleration, constant_velocity, motion_model

steps = st.floats(0.01, 5.0)
densities = st.floats(0.0, 10.0)


@pytest.mark.parametrize("model", [constant_velocity(1.96), constant_acceleration(0.5)])
@given(dt=steps)
def test_noise_is_symmetric_positive_semidefinite(model, dt: float) -> None:
    _, q = model.matrices(dt)
    np.testing.assert_allclose(q, q.T, atol=0)
    assert np.linalg.eigvalsh(q).min() >= -1e-12 * max(1.0, np.abs(q).max())


@pytest.mark.parametrize("model", [constant_velocity(1.96), constant_acceleration(0.7)])
@given(dt=steps)
def test_discretisation_composes_over_two_half_steps(model, dt: float) -> None:
    """An exact discretisation satisfies F(2T) = F(T)^2 and Q(2T) = F(T) Q(T) F(T)^T + Q(T)."""
    f1, q1 = model.matrices(dt)
    f2, q2 = model.matrices(2 * dt)
    np.testing.assert_allclose(f2, f1 @ f1, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(q2, f1 @ q1 @ f1.T + q1, rtol=1e-9, atol=1e-12)


def test_constant_velocity_moves_in_a_straight_line() -> None:
    model = constant_velocity(1.0)
    state = np.array([10.0, -5.0, 3.0, 4.0])
    np.testing.assert_allclose(model.propagate(state, 2.0), [16.0, 3.0, 3.0, 4.0])


def test_constant_acceleration_follows_the_parabola() -> None:
    model = constant_acceleration(1.0)
    state = np.array([0.0, 0.0, 1.0, 2.0, 0.5, -1.0])
    t = 4.0
    expected = [1.0 * t + 0.25 * t**2, 2.0 * t - 0.5 * t**2, 1.0 + 0.5 * t, 2.0 - t, 0.5, -1.0]
    np.testing.assert_allclose(model.propagate(state, t), expected)


def test_white_noise_acceleration_velocity_variance_grows_as_q_t() -> None:
    _, q = constant_velocity(1.96).matrices(1.0)
    # wang2012 section 5: 1.4 m/s velocity noise per 1 s step <=> q = 1.96 m^2/s^3.
    assert np.sqrt(q[2, 2]) == pytest.approx(1.4)
    assert q[0, 0] == pytest.approx(1.96 / 3.0)


@given(densities)
def test_noise_scales_linearly_with_density(q: float) -> None:
    np.testing.assert_allclose(constant_velocity(q).matrices(1.0)[1], q * constant_velocity(1.0).matrices(1.0)[1])


def test_matrices_are_read_only_and_bad_inputs_are_rejected() -> None:
    f, q = constant_velocity(1.0).matrices(1.0)
    with pytest.raises(ValueError):
        f[0, 0] = 2.0
    with pytest.raises(ValueError, match="positive"):
        constant_velocity(1.0).matrices(0.0)
    with pytest.raises(ValueError, match="unknown motion model"):
        motion_model("ct", 1.0)
    with pytest.raises(ValueError, match="noise_density"):
        constant_velocity(float("nan"))


@pytest.mark.parametrize("model", [constant_velocity(1.96), constant_acceleration(0.5)])
def test_horizon_matrices_are_the_step_composed_j_times(model) -> None:
    f, q = model.matrices(0.5)
    powers, noises = model.horizon_matrices(0.5, 4)
    assert powers.shape == noises.shape == (4, model.dim, model.dim)
    power, noise = np.eye(model.dim), np.zeros((model.dim, model.dim))
    for j in range(4):
        power, noise = f @ power, f @ noise @ f.T + q
        np.testing.assert_allclose(powers[j], power, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(noises[j], noise, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError):
        powers[0, 0, 0] = 2.0
    with pytest.raises(ValueError, match="steps"):
        model.horizon_matrices(0.5, 0)
    with pytest.raises(ValueError, match="positive"):
        model.horizon_matrices(-1.0, 3)
