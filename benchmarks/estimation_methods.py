"""The filters of ``gcs-bench estimation``, one step at a time, and their timing alternated step by step.

Each method is a *stepper* factory: ``factory(data, run)`` returns ``step(k) -> (mean, cov)``,
which runs the filter's predict + update for step ``k`` of run ``run``. :func:`run_methods`
builds every method's stepper for a run and then, at each step, runs the methods one after
the other, in an order that rotates from step to step, timing each step on its own
(``time.perf_counter``): the methods see the same machine, step by step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.iterated import iterated_update
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from sim_vehicles.truth.sensor import exact_measurements

__all__ = ["Step", "Stepper", "FilterRun", "duif_stepper", "duif_numpy_stepper", "duif_eq13_stepper",
           "filterpy_stepper", "run_methods", "observe", "ACCEL_PSD", "SENSOR_STD", "NS_PER_S"]

ACCEL_PSD = 1.96  # m^2/s^3: wang2012's 1.4 m/s velocity noise per 1 s step
SENSOR_STD = (10.0, 0.05, 0.05)  # range m, azimuth rad, elevation rad (wang2012 section 5)
NS_PER_S = 1_000_000_000

Step = Callable[[int], tuple[NDArray[np.float64], NDArray[np.float64]]]
Stepper = Callable[..., Step]
"""``factory(data, run) -> step``; ``data`` an :class:`benchmarks.estimation.EstimationDataset`."""


@dataclass(frozen=True)
class FilterRun:
    """Estimates (R, K, n), covariances (R, K, n, n) and wall-clock seconds of each step (R, K)."""

    means: NDArray[np.float64]
    covs: NDArray[np.float64]
    step_seconds: NDArray[np.float64]


def observe(target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Range, azimuth and elevation of a ground target seen from each vehicle (the simulator's formulas)."""
    target_xyz = np.concatenate([target_xy, np.zeros(target_xy.shape[:-1] + (1,))], axis=-1)
    return exact_measurements(target_xyz, vehicle_xyz)


def sensor_model() -> SensorModel:
    return SensorModel.range_bearing(*SENSOR_STD)


def _duif(data, run: int, sensor: SensorModel | None, second_order: bool, iterated: bool, compiled: bool) -> Step:
    uif = UnscentedInformationFilter(constant_velocity(ACCEL_PSD), second_order=second_order)
    model = sensor or sensor_model()
    state = {"estimate": GaussianEstimate(data.initial_mean[run], data.initial_cov, 0)}

    def step(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        vehicles, z = data.vehicle_xyz[run, k], data.measurements[run, k]
        prior = uif.predict(state["estimate"], int(round(k * data.step_s * NS_PER_S)))
        if iterated:
            estimate = iterated_update(uif, prior, [(model, z, vehicles, None)], compiled)
        else:
            estimate = uif.update(uif.contribution(prior, model, z, vehicles))
        state["estimate"] = estimate
        return estimate.mean, estimate.cov

    return step


def duif_stepper(data, run: int, sensor: SensorModel | None = None) -> Step:
    """The daemon's update: predict, then :func:`~gcs.core.filters.iterated.iterated_update` (the compiled
    kernel when numba is installed), second-order ``R``."""
    return _duif(data, run, sensor, True, True, True)


def duif_numpy_stepper(data, run: int, sensor: SensorModel | None = None) -> Step:
    """The daemon's update in its numpy form (``compiled=False``): what runs without numba."""
    return _duif(data, run, sensor, True, True, False)


def duif_eq13_stepper(data, run: int, sensor: SensorModel | None = None) -> Step:
    """Eq. (12)-(13) as printed (``second_order=False``), one linearisation, numpy."""
    return _duif(data, run, sensor, False, False, False)


def filterpy_stepper(data, run: int) -> Step:
    """FilterPy's UKF with every vehicle's measurement stacked (module docstring of benchmarks.estimation)."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    f, q = constant_velocity(ACCEL_PSD).matrices(data.step_s)
    _, _, vehicles = data.shape
    azimuths = slice(1, None, 3)

    def fx(x: NDArray, dt: float) -> NDArray:
        return f @ x

    def hx(x: NDArray, vehicle_xyz: NDArray) -> NDArray:
        return observe(x[:2], vehicle_xyz).ravel()

    def residual_z(a: NDArray, b: NDArray) -> NDArray:
        y = a - b
        y[azimuths] = (y[azimuths] + np.pi) % (2.0 * np.pi) - np.pi
        return y

    def z_mean(sigmas: NDArray, weights: NDArray) -> NDArray:
        z = weights @ sigmas
        z[azimuths] = np.arctan2(weights @ np.sin(sigmas[:, azimuths]), weights @ np.cos(sigmas[:, azimuths]))
        return z

    points = MerweScaledSigmaPoints(4, alpha=1.0, beta=2.0, kappa=-1.0)
    ukf = UnscentedKalmanFilter(4, 3 * vehicles, data.step_s, hx, fx, points, residual_z=residual_z, z_mean_fn=z_mean)
    ukf.x = data.initial_mean[run].copy()
    ukf.P = data.initial_cov.copy()
    ukf.Q = q.copy()
    ukf.R = np.diag(np.tile(np.square(SENSOR_STD), vehicles))

    def step(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if k > 0:
            ukf.predict()
        # FilterPy's update reuses the propagated sigma points, which lack Q (and are zeros
        # before the first predict); redraw them from (x, P) as the textbook UKF and our UIF do.
        ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
        ukf.update(data.measurements[run, k].ravel(), vehicle_xyz=data.vehicle_xyz[run, k])
        return ukf.x, ukf.P  # new arrays at every update: stored before the next

    return step


def run_methods(data, methods: dict[str, Stepper], progress: Callable[[str], None] | None = None
                ) -> dict[str, FilterRun]:
    """Every method on every run, the methods alternated step by step in a rotating order (``progress`` hears
    every tenth run)."""
    from time import perf_counter

    runs, steps, _ = data.shape
    names = list(methods)
    means = {name: np.empty((runs, steps) + data.initial_mean.shape[1:]) for name in names}
    covs = {name: np.empty((runs, steps) + data.initial_cov.shape) for name in names}
    seconds = {name: np.empty((runs, steps)) for name in names}
    every = max(1, runs // 10)
    for run in range(runs):
        if progress is not None and run and run % every == 0:
            progress(f"run {run}/{runs}")
        steppers = {name: methods[name](data, run) for name in names}
        for k in range(steps):
            shift = (run * steps + k) % len(names)
            for name in names[shift:] + names[:shift]:
                start = perf_counter()
                mean, cov = steppers[name](k)
                seconds[name][run, k] = perf_counter() - start
                means[name][run, k], covs[name][run, k] = mean, cov
    return {name: FilterRun(means[name], covs[name], seconds[name]) for name in names}
