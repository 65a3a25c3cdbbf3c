"""The routeless navigation filter for many vehicles at once: :func:`~gcs.core.navigation.skf.gaussian_update`,
batched.

Without route segments feng2019's SKF has one mode, and its update is one extended
Kalman filter (:func:`gcs.core.navigation.skf.gaussian_update`): the INS prediction of
eq. (1), then the GPS fix (eq. 4-5), the GNSS velocity and the heading in one
update. The daemon runs it for every vehicle's nav reports, five a second each;
one report at a time it costs about 0.17 ms, almost all of it NumPy's per-call
overhead on 6 x 6 matrices. Here the same equations run on a stack of V vehicles
(one report each) in the same number of calls.

Index conventions: the leading axis of every array is the vehicle, ``v``; the state
is :data:`~gcs.core.navigation.model.STATE_DIM` = 6, ``[x, y, theta, vx, vy, vtheta]``
(ENU m, rad, m/s, rad/s; :mod:`gcs.core.navigation.model`). Every vehicle in one call
has the same observed components (``rows``, indices into the state); their values
and variances are its own.

Numerically the results equal the one-at-a-time filter's to rounding (about 1e-12
relative; a test holds them to 1e-9): the update solves with ``S`` by LU instead of
Cholesky. Each vehicle's result is computed by itself (stacked products are
evaluated slice by slice), so it does not depend on which other vehicles share the
call: the daemon and ``gcs replay --process`` may batch differently and agree.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gcs.core.geometry import wrap_angle
from gcs.core.navigation.model import STATE_DIM, THETA, VX, VY, X, Y, InsNoise
from gcs.core.navigation.skf import GAP_TOLERANCE_S, NS_PER_S, NavGaussian, NavMeasurement, NavParams, gaussian_update

__all__ = ["gaussian_updates", "ins_predict_many", "update_many", "GPS_ROWS", "VELOCITY_ROWS", "HEADING_ROWS"]

GPS_ROWS = (X, Y)
"""State components a GPS fix observes (eq. 5)."""
VELOCITY_ROWS = (VX, VY)
"""State components the GNSS velocity observes."""
HEADING_ROWS = (THETA,)
"""State component a heading observes (its residual is wrapped)."""
_CARRIED = [X, Y, THETA]
_FOLLOW_THETA = [X, Y, VX, VY]
_DIAGONAL = list(range(STATE_DIM))


def ins_predict_many(means: NDArray[np.float64], covs: NDArray[np.float64], distance_m: NDArray[np.float64],
                     heading_change_rad: NDArray[np.float64], dt_s: NDArray[np.float64], noise: InsNoise
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (1) as an EKF prediction for V vehicles: :func:`~gcs.core.navigation.model.ins_predict` on each.

    Parameters
    ----------
    means : (V, 6), covs : (V, 6, 6)
    distance_m, heading_change_rad, dt_s : (V,)
        Each vehicle's INS increments over its interval ``dt_s`` (> 0).

    Returns
    -------
    means (V, 6) and covariances (V, 6, 6), symmetric.
    """
    count = means.shape[0]
    assert means.shape == (count, STATE_DIM) and covs.shape == (count, STATE_DIM, STATE_DIM)
    if not np.all(dt_s > 0.0):
        raise ValueError(f"INS intervals must be positive, got {dt_s!r}")
    ds, dth = distance_m, heading_change_rad
    theta = means[:, THETA]
    phi, end = theta + 0.5 * dth, theta + dth
    cp, sp, ce, se = np.cos(phi), np.sin(phi), np.cos(end), np.sin(end)
    speed = ds / dt_s
    zero, one = np.zeros(count), np.ones(count)
    new = np.stack([means[:, X] + ds * cp, means[:, Y] + ds * sp, wrap_angle(end), speed * ce, speed * se,
                    dth / dt_s], axis=-1)
    f = np.zeros((count, STATE_DIM, STATE_DIM))  # df/dX: x, y, theta carry over; the rest follows theta
    f[:, _CARRIED, _CARRIED] = 1.0
    f[:, _FOLLOW_THETA, THETA] = np.stack([-ds * sp, ds * cp, -speed * se, speed * ce], axis=-1)
    g = np.stack([cp, -0.5 * ds * sp,  # df/du, u = (delta_s, delta_theta), rows x, y, theta, vx, vy, vtheta
                  sp, 0.5 * ds * cp,
                  zero, one,
                  ce / dt_s, -speed * se,
                  se / dt_s, speed * ce,
                  zero, one / dt_s], axis=-1).reshape(count, STATE_DIM, 2)
    variances = np.stack([noise.distance_std_m**2 * dt_s + (noise.distance_scale_std * ds) ** 2,
                          noise.heading_std_rad**2 * dt_s + (noise.heading_drift_std_rad_s * dt_s) ** 2], axis=-1)
    q = (g * variances[:, None, :]) @ g.swapaxes(-1, -2)
    q[:, _DIAGONAL, _DIAGONAL] += np.stack([noise.position_std_m**2 * dt_s, noise.position_std_m**2 * dt_s, zero,
                                           np.full(count, noise.velocity_std_mps**2),
                                           np.full(count, noise.velocity_std_mps**2),
                                           np.full(count, noise.turn_rate_std_rad_s**2)], axis=-1)
    predicted = f @ covs @ f.swapaxes(-1, -2) + q
    return new, 0.5 * (predicted + predicted.swapaxes(-1, -2))


def update_many(means: NDArray[np.float64], covs: NDArray[np.float64], rows: tuple[int, ...],
                values: NDArray[np.float64], variances: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The Kalman update of V vehicles by direct observations of the state components ``rows``.

    ``H`` selects ``rows`` (so ``H P H^T`` is a sub-block of ``P``) and ``R`` is diagonal;
    a :data:`THETA` row's residual is wrapped. Joseph form, as
    :func:`~gcs.core.filters.kalman.kalman_update`:
    ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x = x^- + K nu``,
    ``P = (I - K H) P (I - K H)^T + K R K^T``.

    Parameters
    ----------
    means : (V, 6), covs : (V, 6, 6)
    rows : tuple of int, m of them
    values, variances : (V, m)
        Each vehicle's observed values and their error variances (> 0).
    """
    index = list(rows)
    nu = values - means[:, index]
    for column, row in enumerate(rows):
        if row == THETA:
            nu[:, column] = wrap_angle(nu[:, column])
    ph_t = covs[:, :, index]  # P H^T: (V, 6, m)
    s = ph_t[:, index, :].copy()  # H P H^T: (V, m, m)
    diagonal = np.arange(len(index))
    s[:, diagonal, diagonal] += variances
    gain = np.linalg.solve(s, ph_t.swapaxes(-1, -2)).swapaxes(-1, -2)  # K = P H^T S^-1, S symmetric: (V, 6, m)
    i_kh = np.broadcast_to(np.eye(STATE_DIM), covs.shape).copy()
    i_kh[:, :, index] -= gain
    post = i_kh @ covs @ i_kh.swapaxes(-1, -2) + (gain * variances[:, None, :]) @ gain.swapaxes(-1, -2)
    return means + (gain @ nu[:, :, None])[:, :, 0], 0.5 * (post + post.swapaxes(-1, -2))


def gaussian_updates(params: NavParams, estimates: Sequence[NavGaussian], measurements: Sequence[NavMeasurement]
                     ) -> list[NavGaussian | Exception]:
    """:func:`gaussian_update` of many vehicles, one measurement each: each result, or the error it raised.

    Measurements with INS increments that cover their whole interval (the usual case)
    go through :mod:`gcs.core.navigation.fleet_ekf` together, grouped by the components
    they observe; the others (a gap to bridge by eq. 6, no INS) one at a time. Either
    way a vehicle's result depends on its own estimate and measurement alone.
    """
    results: dict[int, NavGaussian | Exception] = {}
    groups: dict[tuple[int, ...], list[int]] = {}
    for i, (estimate, m) in enumerate(zip(estimates, measurements)):
        gap = (m.stamp_ns - estimate.stamp_ns) / NS_PER_S - (m.ins[2] if m.ins is not None else 0.0)
        if m.ins is None or not m.ins[2] > 0.0 or m.stamp_ns < estimate.stamp_ns or gap > GAP_TOLERANCE_S:
            results[i] = _one_update(params, estimate, m)
            continue
        rows = ((GPS_ROWS if m.gps_fix is not None else ()) + (VELOCITY_ROWS if m.velocity_xy is not None else ())
                + (HEADING_ROWS if m.heading_rad is not None else ()))
        groups.setdefault(rows, []).append(i)
    for rows, members in groups.items():
        means = np.stack([estimates[i].mean for i in members])
        covs = np.stack([estimates[i].cov for i in members])
        ins = np.array([measurements[i].ins for i in members])
        try:
            means, covs = ins_predict_many(means, covs, ins[:, 0], ins[:, 1], ins[:, 2], params.ins)
            if rows:
                values, variances = _observed(params, [measurements[i] for i in members])
                means, covs = update_many(means, covs, rows, values, variances)
                means[:, THETA] = wrap_angle(means[:, THETA])
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):  # one at a time, each with its own error
            for i in members:
                results[i] = _one_update(params, estimates[i], measurements[i])
            continue
        for slot, i in enumerate(members):
            results[i] = NavGaussian(measurements[i].stamp_ns, means[slot], covs[slot])
    return [results[i] for i in range(len(estimates))]


def _one_update(params: NavParams, estimate: NavGaussian, measurement: NavMeasurement) -> NavGaussian | Exception:
    """:func:`gaussian_update` alone: its result, or the error it raised."""
    try:
        return gaussian_update(params, estimate, measurement)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
        return error


def _observed(params: NavParams, measurements: Sequence[NavMeasurement]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Values and variances (V, m) of what :func:`common_observations` observes, in its order."""
    values, variances = [], []
    for m in measurements:
        v, r = [], []
        fix = m.gps_fix
        if fix is not None:
            std = max(float(fix[1]), params.gps_min_std_m)
            v += [fix[0][0], fix[0][1]]
            r += [std**2, std**2]
        if m.velocity_xy is not None:
            v += [m.velocity_xy[0], m.velocity_xy[1]]
            r += [params.velocity_std_mps**2] * 2
        if m.heading_rad is not None:
            v.append(m.heading_rad)
            r.append(params.heading_std_rad**2)
        values.append(v)
        variances.append(r)
    return np.array(values, dtype=np.float64), np.array(variances, dtype=np.float64)
