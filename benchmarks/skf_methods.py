"""The filters ``gcs-bench skf`` compares, each run on one run of a :class:`~benchmarks.skf.SkfDataset`.

* ``skf_cf``: feng2019's switching Kalman filter, centralised fusion
  (:func:`gcs.core.navigation.skf.nav_update`): INS eq. (1), GPS eq. (4)-(5) and the
  map observation eq. (2)-(3) of every candidate route segment;
* ``skf_df``: distributed fusion, Carlson's no-reset federated filter
  (:mod:`gcs.core.navigation.federated`);
* ``ins_gps``: the same filter without the map (one mode: an INS/GPS EKF), to
  show what the map adds;
* ``filterpy_imm``: FilterPy's ``IMMEstimator`` of two ``KalmanFilter`` s on the
  paper's linear model eq. (6), ``X_t = A X_{t-1} + v_t`` (constant velocity and
  turn rate), quiet and manoeuvring process noise;
* ``filterpy_kf``: one ``KalmanFilter`` on the same model, intermediate noise.

The linear filters cannot use eq. (1) (it is non-linear in the heading) or the
map (its observation depends on the mode's own estimate); they see the same data
as ``Y_t = C X_t + w_t``: the GPS position, the dead-reckoned heading
``theta_0 + sum delta_theta`` (from the common prior's heading) and the INS
velocity ``delta_s / dt (cos, sin)`` of that heading, and ``delta_theta / dt``.
Their heading is unwrapped (the snake stays within 65 +- 35 deg).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter
from numpy.typing import NDArray

from benchmarks.skf import INS, STEP_S, SkfDataset
from gcs.core.navigation.federated import federated_start, federated_update
from gcs.core.navigation.model import InsNoise
from gcs.core.navigation.route import route_segments
from gcs.core.navigation.skf import NavMeasurement, NavParams, from_gaussian, nav_update

__all__ = ["METHODS", "MethodRun", "NAV_PARAMS", "run_method"]

METHODS = ("skf_cf", "skf_df", "ins_gps", "filterpy_imm", "filterpy_kf")
NS_PER_S = 1_000_000_000

NAV_PARAMS = NavParams(
    ins=InsNoise(distance_std_m=INS.distance_std_m, distance_scale_std=3.0 * abs(INS.distance_scale_error),
                 heading_std_rad=INS.heading_std_rad, heading_drift_std_rad_s=2.0 * abs(INS.heading_drift_rad_s),
                 velocity_std_mps=2.0, turn_rate_std_rad_s=0.01),
    map_across_std_m=10.0, map_heading_std_rad=0.1, candidate_radius_m=150.0, max_candidates=4,
)
"""Our filter's parameters. INS: the data's noise figures; its biases (1% scale error, 5e-4 rad/s
drift), which six states cannot hold, allowed for as white noise three and two times as large: with
the scale error's own 1%, the weak 30 m GPS cannot stop the along-track error accumulating (25 m RMS
along the track, position NEES 14 instead of 2). 2 m/s and 0.01 rad/s for the speed and turn rate
changing within a second (the snake's lateral acceleration reaches 26 m/s^2). Map: 10 m across a
segment (the stored points' 5 m plus the chord's sagitta) and 0.1 rad of heading."""

LINEAR_R_STD = np.array([0.0, 0.0, 0.05, 10.0, 10.0, 0.005])
"""Measurement noise of the linear filters' heading, velocity and turn rate (the GPS entries come
from the fix): 0.05 rad of dead-reckoned heading (the prior's), hence 10 m/s of velocity at 200 m/s."""
IMM_PSD = ((1.0, 1e-5), (1000.0, 1e-2))
"""(acceleration m^2/s^3, turn rad^2/s^3) process noise of the IMM's quiet and manoeuvring modes."""
KF_PSD = (100.0, 1e-3)
IMM_TRANSITION = np.array([[0.95, 0.05], [0.05, 0.95]])
"""Row-stochastic, ``M[i, j] = P(next = j | now = i)``, as FilterPy's code uses it."""


@dataclass(frozen=True)
class MethodRun:
    """One method on one run: estimates (K, 6), covariances (K, 6, 6), wall-clock seconds for the run."""

    means: NDArray[np.float64]
    covs: NDArray[np.float64]
    seconds: float


def _measurements(data: SkfDataset, run: int) -> list[NavMeasurement]:
    out = []
    for k in range(data.steps):
        fix = data.gps_xy[run, k]
        has_fix = bool(np.isfinite(fix).all())
        out.append(NavMeasurement((k + 1) * NS_PER_S, ins=tuple(float(v) for v in data.ins[run, k]),
                                  gps_xy=fix if has_fix else None,
                                  gps_std_m=float(data.gps_std_m[run, k]) if has_fix else None))
    return out


def _run_nav(data: SkfDataset, run: int, method: str) -> MethodRun:
    measurements = _measurements(data, run)
    route = route_segments(data.routes[run]) if method != "ins_gps" else ()
    means, covs = np.zeros((data.steps, 6)), np.zeros((data.steps, 6, 6))
    start = time.perf_counter()
    estimate = from_gaussian(0, data.initial_mean[run], data.initial_cov)
    if method == "skf_df":
        estimate = federated_start(estimate)
    for k, m in enumerate(measurements):
        if method == "skf_df":
            estimate = federated_update(NAV_PARAMS, estimate, m, route)
        else:
            estimate = nav_update(NAV_PARAMS, estimate, m, route)
        means[k], covs[k] = estimate.mean, estimate.cov
    return MethodRun(means, covs, time.perf_counter() - start)


def _linear_model(accel_psd: float, turn_psd: float) -> KalmanFilter:
    kf = KalmanFilter(dim_x=6, dim_z=6)
    dt = STEP_S
    kf.F = np.eye(6)
    kf.F[0, 3] = kf.F[1, 4] = kf.F[2, 5] = dt  # eq. (6): x += vx dt, y += vy dt, theta += vtheta dt
    block = np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
    kf.Q = np.zeros((6, 6))
    for (p, v), psd in (((0, 3), accel_psd), ((1, 4), accel_psd), ((2, 5), turn_psd)):
        kf.Q[np.ix_((p, v), (p, v))] = psd * block
    kf.H = np.eye(6)
    return kf


def _linear_observations(data: SkfDataset, run: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """z (K, 6) and the diagonal of R (K, 6) of the linear filters (module docstring)."""
    distance, turn, dt = data.ins[run].T
    heading = data.initial_mean[run, 2] + np.cumsum(turn)
    speed = distance / dt
    z = np.column_stack([data.gps_xy[run], heading, speed * np.cos(heading), speed * np.sin(heading), turn / dt])
    r = np.tile(LINEAR_R_STD**2, (data.steps, 1))
    has_fix = np.isfinite(z[:, 0])
    r[:, 0] = r[:, 1] = np.where(has_fix, data.gps_std_m[run] ** 2, 1e12)  # no fix: an uninformative one
    z[~has_fix, :2] = 0.0
    return z, r


def _run_linear(data: SkfDataset, run: int, method: str) -> MethodRun:
    z, r = _linear_observations(data, run)
    psds = IMM_PSD if method == "filterpy_imm" else (KF_PSD,)
    filters = [_linear_model(*psd) for psd in psds]
    for kf in filters:
        kf.x, kf.P = data.initial_mean[run].copy(), data.initial_cov.copy()
    means, covs = np.zeros((data.steps, 6)), np.zeros((data.steps, 6, 6))
    start = time.perf_counter()
    imm = IMMEstimator(filters, np.full(len(filters), 1.0 / len(filters)), IMM_TRANSITION) if len(filters) > 1 else None
    for k in range(data.steps):
        for kf in filters:
            kf.R = np.diag(r[k])
        if imm is not None:
            imm.predict()
            imm.update(z[k])
            means[k], covs[k] = imm.x, imm.P
        else:
            filters[0].predict()
            filters[0].update(z[k])
            means[k], covs[k] = filters[0].x, filters[0].P
    return MethodRun(means, covs, time.perf_counter() - start)


def run_method(data: SkfDataset, run: int, method: str) -> MethodRun:
    """One of :data:`METHODS` on run ``run`` of ``data``."""
    if method in ("skf_cf", "skf_df", "ins_gps"):
        return _run_nav(data, run, method)
    if method in ("filterpy_imm", "filterpy_kf"):
        return _run_linear(data, run, method)
    raise ValueError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")

