"""``gcs-bench skf``: feng2019 section 4 rebuilt, the snake manoeuvre, and the filters run on it.

The experiment (feng2019 section 4; our choices where the paper is silent or
self-contradictory, marked *ours*):

* the UAV flies at 200 m/s from (1100, 900) m (the paper's 1300 m altitude is
  dropped: the filter is horizontal) on the 25 deg azimuth, from north clockwise,
  i.e. an ENU heading of 65 deg; the paper's "5 m/s^2 uniform acceleration" sentence
  (copied from a radar text) contradicts its 200 m/s and is not used (*ours*);
* from 40 s to 90 s it snakes: a lateral offset ``600 sin(2 pi (t - 40) / 30)`` m
  from the base track while the base track advances at 200 m/s; from 90 s to 120 s
  it flies straight on along its heading at 90 s (*ours*: the paper says
  "straight flight" without a heading);
* 150 Monte Carlo runs, filter step 1 s.

Sensor data come from the simulator's models (``sim_vehicles.truth``), not from
the filters' own: INS increments from :class:`~sim_vehicles.truth.ins.InsModel`
drawn every 0.05 s of the exact path (the odometer's chord lengths, as the
simulated airframe's) and summed per second; GPS from
:class:`~sim_vehicles.truth.gps.GpsModel` at 1 Hz. The paper gives no sensor
noise; ours (:data:`GPS`, :data:`INS`, :data:`MAP_ERROR_M`) are documented in
``docs/benchmarks.md``. The map database (eq. 2-3) is the true path sampled every
:data:`ROUTE_SPACING_S` of flight (offset from the filter's steps, so the vehicle
is not always at a vertex) with every stored point off by ``N(0, MAP_ERROR_M^2)``
per axis, as a database's points are.

Methods, all on the same data (:mod:`benchmarks.skf_methods`): ``skf_cf`` and
``skf_df`` (feng2019), ``ins_gps`` (our filter without the map: one mode),
``filterpy_imm`` and ``filterpy_kf`` (FilterPy's ``IMMEstimator`` and
``KalmanFilter`` on the paper's linear model eq. 6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.config.simulation import GpsConfig, InsConfig
from gcs.core.geometry import wrap_angle
from sim_vehicles.truth.gps import GpsModel
from sim_vehicles.truth.ins import InsModel

__all__ = ["SPEED_MPS", "GPS", "INS", "MAP_ERROR_M", "SkfDataset", "snake_truth", "generate_dataset"]

SPEED_MPS = 200.0
START_XY = (1100.0, 900.0)
HEADING_RAD = math.radians(90.0 - 25.0)  # 25 deg azimuth (from north, clockwise) in ENU
AMPLITUDE_M = 600.0
OMEGA_RAD_S = 2.0 * math.pi / 30.0
SNAKE_S = (40.0, 90.0)
DURATION_S = 120.0
STEP_S = 1.0
PHYSICS_STEP_S = 0.05
ROUTE_SPACING_S = 1.3
"""Map database: one stored route point per 1.3 s of flight (about 260 m)."""
MAP_ERROR_M = 5.0
"""Standard deviation of every stored route point, per axis (metres)."""
GPS = GpsConfig(horizontal_std_m=30.0, vertical_std_m=45.0, bias_std_m=0.0)
"""GPS of a jammed or degraded receiver: 30 m white noise per axis, 1 Hz (ours; the paper gives none)."""
INS = InsConfig()
"""The project's default INS: 1% distance scale error, 0.5 m/sqrt(s), 5e-4 rad/s gyro drift, 2e-3 rad/sqrt(s)."""
INITIAL_STD = np.array([30.0, 30.0, 0.05, 10.0, 10.0, 0.01])
"""Prior spread of every filter: position, heading, velocity, turn rate (ours)."""


def snake_truth(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """The true state ``[x, y, theta, vx, vy, vtheta]`` at times ``t`` (K,), shape (K, 6).

    Base track ``p0 + v t u`` (``u`` the 65 deg ENU unit vector) plus ``d(t) n``
    (``n`` its left normal) with ``d = A sin(omega (t - 40))`` during the snake; after
    90 s, straight on with the velocity at 90 s.
    """
    t = np.asarray(t, dtype=np.float64)
    u = np.array([math.cos(HEADING_RAD), math.sin(HEADING_RAD)])
    n = np.array([-u[1], u[0]])
    start, end = SNAKE_S
    tau = np.clip(t, start, end) - start
    snaking = (t >= start) & (t <= end)
    d = AMPLITUDE_M * np.sin(OMEGA_RAD_S * tau)
    d_dot = np.where(snaking, AMPLITUDE_M * OMEGA_RAD_S * np.cos(OMEGA_RAD_S * tau), 0.0)
    d_ddot = np.where(snaking, -AMPLITUDE_M * OMEGA_RAD_S**2 * np.sin(OMEGA_RAD_S * tau), 0.0)
    after = t > end
    d_end_dot = AMPLITUDE_M * OMEGA_RAD_S * math.cos(OMEGA_RAD_S * (end - start))
    d = np.where(after, d + d_end_dot * (t - end), d)
    d_dot = np.where(after, d_end_dot, d_dot)
    xy = np.asarray(START_XY) + np.outer(SPEED_MPS * t, u) + np.outer(d, n)
    velocity = np.outer(np.full_like(t, SPEED_MPS), u) + np.outer(d_dot, n)
    heading = HEADING_RAD + np.arctan2(d_dot, SPEED_MPS)
    turn_rate = SPEED_MPS * d_ddot / (SPEED_MPS**2 + d_dot**2)
    return np.column_stack([xy, wrap_angle(heading), velocity, turn_rate])


@dataclass(frozen=True)
class SkfDataset:
    """R runs of K filter steps (t = 1..K s) of the snake experiment.

    Attributes
    ----------
    truth : (K + 1, 6)
        True state at t = 0..K (the same path in every run).
    ins : (R, K, 3)
        ``(distance_m, heading_change_rad, dt_s)`` over each second.
    gps_xy : (R, K, 2)
        GPS fixes, NaN without one; ``gps_std_m`` (R, K) the receiver's reported 1-sigma.
    routes : (R, P, 2)
        Each run's map database (stored route points).
    initial_mean : (R, 6)
        Every filter's prior mean, drawn from ``N(truth[0], diag(INITIAL_STD^2))``.
    """

    truth: NDArray[np.float64]
    ins: NDArray[np.float64]
    gps_xy: NDArray[np.float64]
    gps_std_m: NDArray[np.float64]
    routes: NDArray[np.float64]
    initial_mean: NDArray[np.float64]

    @property
    def runs(self) -> int:
        return self.ins.shape[0]

    @property
    def steps(self) -> int:
        return self.ins.shape[1]

    @property
    def initial_cov(self) -> NDArray[np.float64]:
        return np.diag(INITIAL_STD**2)


def generate_dataset(runs: int, seed: int, duration_s: float = DURATION_S,
                     gps_outage_s: tuple[float, float] | None = None) -> SkfDataset:
    """The experiment's data, reproducible from ``seed`` (one generator per run: run r is the same in any batch).

    ``gps_outage_s``: no GPS fix in ``[start, end)`` seconds (not in the paper).
    """
    steps = int(round(duration_s / STEP_S))
    per_step = int(round(STEP_S / PHYSICS_STEP_S))
    fine_t = np.arange(steps * per_step + 1) * PHYSICS_STEP_S
    fine = snake_truth(fine_t)
    chords = np.hypot(*np.diff(fine[:, :2], axis=0).T)
    turns = wrap_angle(np.diff(fine[:, 2]))
    truth = fine[::per_step]
    route_t = np.arange(-3.0, duration_s + 5.0, ROUTE_SPACING_S)
    route_true = snake_truth(route_t)[:, :2]
    ins_model, gps_model = InsModel(INS), GpsModel(GPS)
    ins = np.zeros((runs, steps, 3))
    gps_xy = np.full((runs, steps, 2), np.nan)
    gps_std = np.zeros((runs, steps))
    routes = np.zeros((runs,) + route_true.shape)
    initial = np.zeros((runs, 6))
    for r in range(runs):
        rng_ins, rng_gps, rng_map = (np.random.default_rng(s) for s in np.random.SeedSequence([seed, r]).spawn(3))
        initial[r] = truth[0] + rng_map.standard_normal(6) * INITIAL_STD
        initial[r, 2] = wrap_angle(initial[r, 2])
        routes[r] = route_true + rng_map.standard_normal(route_true.shape) * MAP_ERROR_M
        state = gps_model.start(rng_gps)
        for k in range(steps):
            block = slice(k * per_step, (k + 1) * per_step)
            increments = [ins_model.increment(float(d), float(a), PHYSICS_STEP_S, rng_ins)
                          for d, a in zip(chords[block], turns[block])]
            ins[r, k] = (sum(d for d, _ in increments), sum(a for _, a in increments), STEP_S)
            state, reading = gps_model.read(state, np.append(truth[k + 1, :2], 1300.0), STEP_S, rng_gps)
            gps_std[r, k] = reading.horizontal_std_m
            t = (k + 1) * STEP_S
            if reading.position_enu_m is not None and not (gps_outage_s and gps_outage_s[0] <= t < gps_outage_s[1]):
                gps_xy[r, k] = reading.position_enu_m[:2]
    return SkfDataset(truth, ins, gps_xy, gps_std, routes, initial)
