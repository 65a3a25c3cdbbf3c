"""A vehicle's own horizontal navigation: state, INS motion (feng2019 eq. 1), GPS and other observations.

State (feng2019 section 2), ENU, SI units, indices :data:`X` .. :data:`VTHETA`::

    [x, y, theta, vx, vy, vtheta]      m, m, rad, m/s, m/s, rad/s

``theta`` is the heading, ENU from east counter-clockwise, kept wrapped to (-pi, pi];
``(vx, vy)`` the ground velocity and ``vtheta`` the turn rate.

INS motion, eq. (1), driven by the increments ``(delta_s, delta_theta)`` over ``dt``
(:func:`ins_predict`); with ``phi = theta + delta_theta / 2`` and ``theta' = theta + delta_theta``:

.. math::
    x' = x + \\delta_s \\cos\\phi, \\quad y' = y + \\delta_s \\sin\\phi, \\quad \\theta' = \\theta + \\delta_\\theta,

    (v_x', v_y') = \\frac{\\delta_s}{dt} (\\cos\\theta', \\sin\\theta'), \\quad v_\\theta' = \\frac{\\delta_\\theta}{dt}

(the velocity along the heading at the end of the interval, the mean speed over it).
This is an extended Kalman prediction: ``P' = F P F^T + G Q_u G^T + Q_0`` with
``F = df/dX``, ``G = df/du``, ``Q_u = diag(sigma_s^2, sigma_theta^2)`` the
variances of the increments and ``Q_0`` a small diagonal for what eq. (1) leaves
out (:class:`InsNoise`).

Without INS, the linear model of eq. (6), ``X_t = A X_{t-1} + v_t``: constant
velocity and turn rate, white acceleration noise (:func:`cv_predict`).

Observations (all linear in the state, :class:`~gcs.core.filters.kalman.Observation`):
GPS position, eq. (5), with covariance eq. (4) (:func:`gps_observation`); ground
velocity (:func:`velocity_observation`); heading (:func:`heading_observation`).
The map observation of eq. (2)-(3) is in :mod:`gcs.core.navigation.route`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.kalman import Observation
from gcs.core.geometry import wrap_angle

__all__ = ["X", "Y", "THETA", "VX", "VY", "VTHETA", "STATE_DIM", "ANGLE_INDICES", "InsNoise", "InsDatasheet", "ScenarioWithIns", "ins_predict",
           "cv_predict", "gps_observation", "velocity_observation", "heading_observation"]

X, Y, THETA, VX, VY, VTHETA = range(6)
"""Indices of the state vector."""
STATE_DIM = 6
ANGLE_INDICES = (THETA,)
"""State components that are angles (wrapped in residuals and collapses)."""

_H_POSITION = np.zeros((2, STATE_DIM))
_H_POSITION[0, X] = _H_POSITION[1, Y] = 1.0
_H_VELOCITY = np.zeros((2, STATE_DIM))
_H_VELOCITY[0, VX] = _H_VELOCITY[1, VY] = 1.0
_H_HEADING = np.zeros((1, STATE_DIM))
_H_HEADING[0, THETA] = 1.0


class InsDatasheet(Protocol):
    """The INS figures of a scenario's ``[simulation.ins]`` (:class:`gcs.config.simulation.InsConfig`)."""

    @property
    def distance_std_m(self) -> float: ...
    @property
    def distance_scale_error(self) -> float: ...
    @property
    def heading_std_rad(self) -> float: ...
    @property
    def heading_drift_rad_s(self) -> float: ...


class _SimulationWithIns(Protocol):
    @property
    def ins(self) -> InsDatasheet: ...


class ScenarioWithIns(Protocol):
    """What :meth:`NavParams.from_scenario` reads of a scenario: ``simulation.ins``."""

    @property
    def simulation(self) -> _SimulationWithIns: ...


@dataclass(frozen=True)
class InsNoise:
    """What the filter assumes of the INS increments (the truth's errors are in ``sim_vehicles.truth.ins``).

    Over an interval ``dt`` with distance ``delta_s``:
    ``var(delta_s) = distance_std_m^2 dt + (distance_scale_std delta_s)^2`` and
    ``var(delta_theta) = heading_std_rad^2 dt + (heading_drift_std_rad_s dt)^2``.
    The scale error and the gyro drift are biases in truth; the filter's state has
    no room for them (feng2019's six states), so they are allowed for as white noise.

    Attributes
    ----------
    distance_std_m : float
        Random-walk distance noise, m per sqrt(s).
    distance_scale_std : float
        Allowance for the distance scale error (fraction).
    heading_std_rad : float
        Random-walk heading noise, rad per sqrt(s).
    heading_drift_std_rad_s : float
        Allowance for the gyro drift, rad/s.
    position_std_m : float
        Extra white position noise per sqrt(s) (modelling errors of eq. 1), m.
    velocity_std_mps, turn_rate_std_rad_s : float
        Error of taking the interval's mean speed along the final heading, and its mean
        turn rate, for the velocity and turn rate at its end (accelerations within the
        interval). They also keep the velocity block of ``P`` regular: the increments
        alone drive three velocity states with two noises.
    """

    distance_std_m: float = 0.5
    distance_scale_std: float = 0.01
    heading_std_rad: float = 0.002
    heading_drift_std_rad_s: float = 0.001
    position_std_m: float = 0.1
    velocity_std_mps: float = 0.5
    turn_rate_std_rad_s: float = 0.005


def ins_predict(mean: NDArray[np.float64], cov: NDArray[np.float64], distance_m: float, heading_change_rad: float,
                dt_s: float, noise: InsNoise, scale: float = 1.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (1) as an EKF prediction (module docstring); ``scale`` multiplies the process noise.

    Returns the predicted mean (6,) and covariance (6, 6).
    """
    assert mean.shape == (STATE_DIM,) and cov.shape == (STATE_DIM, STATE_DIM)
    if not dt_s > 0.0:
        raise ValueError(f"INS interval must be positive, got {dt_s!r}")
    ds, dth = float(distance_m), float(heading_change_rad)
    phi = mean[THETA] + 0.5 * dth
    end = mean[THETA] + dth
    cp, sp, ce, se = math.cos(phi), math.sin(phi), math.cos(end), math.sin(end)
    speed = ds / dt_s
    new = np.array([mean[X] + ds * cp, mean[Y] + ds * sp, wrap_angle(end), speed * ce, speed * se, dth / dt_s])
    f = np.zeros((STATE_DIM, STATE_DIM))  # df/dX: only x, y, theta carry over
    f[X, X] = f[Y, Y] = f[THETA, THETA] = 1.0
    f[X, THETA], f[Y, THETA] = -ds * sp, ds * cp
    f[VX, THETA], f[VY, THETA] = -speed * se, speed * ce
    g = np.array([  # df/du, u = (delta_s, delta_theta)
        [cp, -0.5 * ds * sp],
        [sp, 0.5 * ds * cp],
        [0.0, 1.0],
        [ce / dt_s, -speed * se],
        [se / dt_s, speed * ce],
        [0.0, 1.0 / dt_s],
    ])
    var_s = noise.distance_std_m**2 * dt_s + (noise.distance_scale_std * ds) ** 2
    var_th = noise.heading_std_rad**2 * dt_s + (noise.heading_drift_std_rad_s * dt_s) ** 2
    q = (g * np.array([var_s, var_th])) @ g.T
    q[X, X] += noise.position_std_m**2 * dt_s
    q[Y, Y] += noise.position_std_m**2 * dt_s
    q[VX, VX] += noise.velocity_std_mps**2
    q[VY, VY] += noise.velocity_std_mps**2
    q[VTHETA, VTHETA] += noise.turn_rate_std_rad_s**2
    predicted = f @ cov @ f.T + scale * q
    return new, 0.5 * (predicted + predicted.T)


def cv_predict(mean: NDArray[np.float64], cov: NDArray[np.float64], dt_s: float, accel_psd_m2_s3: float,
               turn_psd_rad2_s3: float, scale: float = 1.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (6) without INS: ``x += vx dt``, ``y += vy dt``, ``theta += vtheta dt``, white acceleration noise.

    Per axis pair (position, rate) the noise is the continuous white-noise
    acceleration ``q [[dt^3/3, dt^2/2], [dt^2/2, dt]]``.
    """
    assert mean.shape == (STATE_DIM,) and cov.shape == (STATE_DIM, STATE_DIM)
    if not dt_s > 0.0:
        raise ValueError(f"interval must be positive, got {dt_s!r}")
    a = np.eye(STATE_DIM)
    a[X, VX] = a[Y, VY] = a[THETA, VTHETA] = dt_s
    new = a @ mean
    new[THETA] = wrap_angle(new[THETA])
    block = np.array([[dt_s**3 / 3.0, dt_s**2 / 2.0], [dt_s**2 / 2.0, dt_s]])
    q = np.zeros((STATE_DIM, STATE_DIM))
    for (p, v), psd in (((X, VX), accel_psd_m2_s3), ((Y, VY), accel_psd_m2_s3), ((THETA, VTHETA), turn_psd_rad2_s3)):
        q[np.ix_((p, v), (p, v))] = psd * block
    predicted = a @ cov @ a.T + scale * q
    return new, 0.5 * (predicted + predicted.T)


def gps_observation(position_xy: NDArray[np.float64], cov_xy: NDArray[np.float64]) -> Observation:
    """Eq. (5) ``[x_GPS, y_GPS] = [I_2 0] X + beta_GPS`` with ``cov(beta_GPS)`` = eq. (4), (2, 2)."""
    return Observation(np.asarray(position_xy, dtype=np.float64).copy(), _H_POSITION, np.asarray(cov_xy, dtype=np.float64))


def velocity_observation(velocity_xy: NDArray[np.float64], std_mps: float) -> Observation:
    """GNSS ground velocity ``(vx, vy)`` with independent errors of ``std_mps`` per axis."""
    return Observation(np.asarray(velocity_xy, dtype=np.float64).copy(), _H_VELOCITY, np.eye(2) * std_mps**2)


def heading_observation(heading_rad: float, std_rad: float) -> Observation:
    """A heading (compass or GNSS course), wrapped residual."""
    return Observation(np.array([float(heading_rad)]), _H_HEADING, np.array([[std_rad**2]]), angle_rows=(0,))
