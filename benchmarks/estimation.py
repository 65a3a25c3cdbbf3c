"""``gcs-bench estimation``: our DUIF against FilterPy's UKF on the same generated data.

The data set is wang2012's sensor set-up: the target follows the
white-noise-acceleration model (eq. 2) and V UAVs loiter around it on a
300 m circle at 25 m/s, at 200, 210, 220, ... m, each measuring range,
azimuth and elevation (eq. 4) with 10 m / 0.05 rad / 0.05 rad noise.
Measurements are generated with the simulator's formulas
(:func:`sim_vehicles.truth.sensor.exact_measurements`), not with the filters'
sensor model, so that one bug cannot hide in both.

Both filters start from the same prior, drawn around the truth from
``N(x_0, P_0)`` so that the PCRLB applies, and see the same measurements:

* ``duif``: :class:`gcs.core.filters.uif.UnscentedInformationFilter` as the
  daemon runs it (its default, ``second_order=True``: ``R`` carries the
  linearisation's second-order variance), every vehicle's contribution on its
  own, fused by summation (eq. 14-15);
* ``duif_eq13``: the same filter with eq. (12)-(13) as printed
  (``second_order=False``), the paper's form;
* ``filterpy_ukf``: ``filterpy.kalman.UnscentedKalmanFilter`` with all
  vehicles' measurements stacked into one 3V vector, the same sigma points
  (alpha 1, beta 2, kappa 3 - n), azimuth residuals wrapped and azimuth
  means taken on the circle. Its sigma points are redrawn from the predicted
  ``(x, P)`` before each update: FilterPy otherwise reuses the propagated
  points, which miss ``Q`` (and are all zero before the first prediction).

Reported per method: position RMSE over all runs and steps, its ratio to the
square root of the mean PCRLB position trace, the average NEES of the full
state (its 95% band for the number of runs is printed beside it), and the
median wall-clock microseconds of one predict + update step. The two
methods run alternately, run by run, so machine noise hits both alike.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from benchmarks.plots import pyplot, save, write_markdown
from gcs.core.filters.uif import GaussianEstimate, UnscentedInformationFilter
from gcs.core.models.motion import constant_velocity
from gcs.core.models.sensor import SensorModel
from gcs.core.pcrlb import pcrlb
from sim_vehicles.truth.sensor import exact_measurements

__all__ = ["EstimationDataset", "generate_dataset", "run_duif", "run_duif_eq13", "run_filterpy_ukf", "evaluate",
           "run_benchmark", "write_plots", "METHOD_NOTES"]

ACCEL_PSD = 1.96  # m^2/s^3: wang2012's 1.4 m/s velocity noise per 1 s step
SENSOR_STD = (10.0, 0.05, 0.05)  # range m, azimuth rad, elevation rad (wang2012 section 5)
ORBIT_RADIUS_M = 300.0
SPEED_MPS = 25.0
INITIAL_STD = (50.0, 50.0, 10.0, 10.0)
NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class EstimationDataset:
    """Generated truth, vehicle positions and measurements for R runs of K steps with V vehicles."""

    step_s: float
    truth: NDArray[np.float64]  # (R, K, 4)
    vehicle_xyz: NDArray[np.float64]  # (R, K, V, 3)
    measurements: NDArray[np.float64]  # (R, K, V, 3): range, azimuth, elevation
    initial_mean: NDArray[np.float64]  # (R, 4)
    initial_cov: NDArray[np.float64]  # (4, 4)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(runs, steps, vehicles)."""
        runs, steps, vehicles, _ = self.vehicle_xyz.shape
        return runs, steps, vehicles


def _observe(target_xy: NDArray[np.float64], vehicle_xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Range, azimuth and elevation of a ground target seen from each vehicle (the simulator's formulas)."""
    target_xyz = np.concatenate([target_xy, np.zeros(target_xy.shape[:-1] + (1,))], axis=-1)
    return exact_measurements(target_xyz, vehicle_xyz)


def generate_dataset(runs: int, steps: int, vehicles: int, seed: int, step_s: float = 1.0) -> EstimationDataset:
    """Truth, loitering vehicles and noisy measurements, reproducible from ``seed``."""
    rng = np.random.default_rng(seed)
    motion = constant_velocity(ACCEL_PSD)
    f, q = motion.matrices(step_s)
    q_factor = np.linalg.cholesky(q)
    initial_cov = np.diag(np.square(INITIAL_STD))
    start = np.array([1500.0, 1500.0, 5.0, 0.0])
    truth = np.empty((runs, steps, 4))
    truth[:, 0] = start
    for k in range(1, steps):
        truth[:, k] = truth[:, k - 1] @ f.T + rng.standard_normal((runs, 4)) @ q_factor.T
    phases = 2.0 * np.pi * np.arange(vehicles) / vehicles
    angles = phases[None, :] + (SPEED_MPS / ORBIT_RADIUS_M) * step_s * np.arange(steps)[:, None]  # (K, V)
    vehicle_xyz = np.empty((runs, steps, vehicles, 3))
    vehicle_xyz[..., 0] = truth[:, :, None, 0] + ORBIT_RADIUS_M * np.cos(angles)
    vehicle_xyz[..., 1] = truth[:, :, None, 1] + ORBIT_RADIUS_M * np.sin(angles)
    vehicle_xyz[..., 2] = 200.0 + 10.0 * np.arange(vehicles)
    noise = rng.standard_normal((runs, steps, vehicles, 3)) * np.asarray(SENSOR_STD)
    measurements = _observe(truth[:, :, None, :2], vehicle_xyz) + noise
    measurements[..., 1] = np.angle(np.exp(1j * measurements[..., 1]))
    initial_mean = start + rng.standard_normal((runs, 4)) @ np.linalg.cholesky(initial_cov).T
    return EstimationDataset(step_s, truth, vehicle_xyz, measurements, initial_mean, initial_cov)


@dataclass(frozen=True)
class FilterRun:
    """Estimates (R, K, n), covariances (R, K, n, n) and per-step wall-clock seconds."""

    means: NDArray[np.float64]
    covs: NDArray[np.float64]
    step_seconds: NDArray[np.float64]


def _sensor() -> SensorModel:
    return SensorModel.range_bearing(*SENSOR_STD)


def run_duif(data: EstimationDataset, run: int, sensor: SensorModel | None = None,
             second_order: bool = True) -> tuple[NDArray, NDArray, list[float]]:
    """One run of the DUIF: every vehicle's contribution on its own, summed (eq. 14-15).

    ``sensor`` is the model the filter assumes (default: the one that generated the data).
    ``second_order`` is the filter's (True, its default and the daemon's; False: eq. (12)-(13) as
    printed). The paper's vehicles stay far from the target, where the two differ little.
    """
    uif = UnscentedInformationFilter(constant_velocity(ACCEL_PSD), second_order=second_order)
    sensor = sensor or _sensor()
    _, steps, _ = data.shape
    estimate = GaussianEstimate(data.initial_mean[run], data.initial_cov, 0)
    means, covs, seconds = np.empty((steps, 4)), np.empty((steps, 4, 4)), []
    for k in range(steps):
        vehicles, z = data.vehicle_xyz[run, k], data.measurements[run, k]
        stamp = int(round(k * data.step_s * NS_PER_S))
        start = time.perf_counter()
        prior = uif.predict(estimate, stamp)
        estimate = uif.update(uif.contribution(prior, sensor, z, vehicles))
        seconds.append(time.perf_counter() - start)
        means[k], covs[k] = estimate.mean, estimate.cov
    return means, covs, seconds


def run_duif_eq13(data: EstimationDataset, run: int) -> tuple[NDArray, NDArray, list[float]]:
    """One run of the DUIF with eq. (12)-(13) as printed (``second_order=False``)."""
    return run_duif(data, run, second_order=False)


def run_filterpy_ukf(data: EstimationDataset, run: int) -> tuple[NDArray, NDArray, list[float]]:
    """One run of FilterPy's UKF with every vehicle's measurement stacked."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    motion = constant_velocity(ACCEL_PSD)
    f, q = motion.matrices(data.step_s)
    _, steps, vehicles = data.shape
    azimuths = slice(1, None, 3)

    def fx(x: NDArray, dt: float) -> NDArray:
        return f @ x

    def hx(x: NDArray, vehicle_xyz: NDArray) -> NDArray:
        return _observe(x[:2], vehicle_xyz).ravel()

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
    means, covs, seconds = np.empty((steps, 4)), np.empty((steps, 4, 4)), []
    for k in range(steps):
        start = time.perf_counter()
        if k > 0:
            ukf.predict()
        # FilterPy's update reuses the propagated sigma points, which lack Q (and are zeros
        # before the first predict); redraw them from (x, P) as the textbook UKF and our UIF do.
        ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
        ukf.update(data.measurements[run, k].ravel(), vehicle_xyz=data.vehicle_xyz[run, k])
        seconds.append(time.perf_counter() - start)
        means[k], covs[k] = ukf.x, ukf.P
    return means, covs, seconds


METHOD_NOTES = {"duif": "the filter as the daemon runs it (second_order=True, the default)",
                "duif_eq13": "eq. (12)-(13) as printed (second_order=False)",
                "filterpy_ukf": "FilterPy's UnscentedKalmanFilter, every vehicle stacked"}
"""What each method is, printed under the table."""
METHODS: dict[str, Callable[[EstimationDataset, int], tuple[NDArray, NDArray, list[float]]]] = {
    "duif": run_duif,
    "duif_eq13": run_duif_eq13,
    "filterpy_ukf": run_filterpy_ukf,
}


def run_methods(data: EstimationDataset, methods: dict = METHODS,
                progress: Callable[[str], None] | None = None) -> dict[str, FilterRun]:
    """Run every method on every run, alternating methods run by run (``progress`` hears every tenth run)."""
    runs, steps, _ = data.shape
    collected = {name: ([], [], []) for name in methods}
    every = max(1, runs // 10)
    for run in range(runs):
        if progress is not None and run and run % every == 0:
            progress(f"run {run}/{runs}")
        for name, method in methods.items():
            means, covs, seconds = method(data, run)
            collected[name][0].append(means)
            collected[name][1].append(covs)
            collected[name][2].extend(seconds)
    return {name: FilterRun(np.stack(m), np.stack(c), np.asarray(s)) for name, (m, c, s) in collected.items()}


def position_bound(data: EstimationDataset) -> NDArray[np.float64]:
    """PCRLB position trace at each step, averaged over the runs' true trajectories, shape (K,)."""
    _, steps, vehicles = data.shape
    bounds = pcrlb(
        constant_velocity(ACCEL_PSD), data.step_s, data.initial_cov, [_sensor()] * vehicles,
        data.vehicle_xyz, np.ones((steps, vehicles), dtype=bool), data.truth,
    )
    return np.trace(bounds[:, :2, :2], axis1=1, axis2=2)


def evaluate(data: EstimationDataset, result: FilterRun, bound_trace: NDArray[np.float64]) -> dict[str, float]:
    """RMSE, RMSE / sqrt(PCRLB), average NEES and median microseconds per step."""
    errors = result.means - data.truth
    squared = np.sum(errors[..., :2] ** 2, axis=-1)
    nees = np.einsum("rki,rki->rk", errors, np.linalg.solve(result.covs, errors[..., None])[..., 0])
    rmse = float(np.sqrt(squared.mean()))
    return {
        "rmse_m": rmse,
        "rmse_over_pcrlb": rmse / float(np.sqrt(bound_trace.mean())),
        "nees": float(nees.mean()),
        "us_per_step_median": float(np.median(result.step_seconds) * 1e6),
    }


def rmse_by_step(data: EstimationDataset, result: FilterRun) -> list[float]:
    """Position RMSE over the runs at each step (m), shape (K,)."""
    squared = np.sum((result.means - data.truth)[..., :2] ** 2, axis=-1)
    return [float(x) for x in np.sqrt(squared.mean(axis=0))]


def nees_band(runs: int, dim: int = 4) -> tuple[float, float]:
    """Two-sided 95% band of the run-averaged NEES of a consistent filter (chi-square, R n dof)."""
    low, high = chi2.ppf([0.025, 0.975], runs * dim) / runs
    return float(low), float(high)


def run_benchmark(runs: int, seed: int, steps: int = 100, vehicle_counts: tuple[int, ...] = (1, 3, 10, 30),
                  table_runs: int = 5, progress: Callable[[str], None] | None = None) -> dict:
    """The whole benchmark: the 3-vehicle comparison over ``runs`` runs, and a table over vehicle counts."""
    say = progress or (lambda _msg: None)
    say(f"3 vehicles: {runs} runs x {steps} steps")
    data = generate_dataset(runs, steps, 3, seed)
    bound = position_bound(data)
    results = run_methods(data, progress=say)
    methods = {name: evaluate(data, result, bound) for name, result in results.items()}
    curves = {"pcrlb_m": [float(x) for x in np.sqrt(bound)],
              **{name: rmse_by_step(data, result) for name, result in results.items()}}
    table = []
    for count in vehicle_counts:
        say(f"table: {count} vehicles, {table_runs} runs")
        small = generate_dataset(table_runs, steps, count, seed + count)
        small_bound = position_bound(small)
        row = {name: evaluate(small, result, small_bound) for name, result in run_methods(small).items()}
        table.append({"vehicles": count, **row})
    speedup = methods["filterpy_ukf"]["us_per_step_median"] / methods["duif"]["us_per_step_median"]
    return {
        "runs": runs, "steps": steps, "seed": seed, "vehicles": 3,
        "nees_band_95": nees_band(runs),
        "methods": methods,
        "speedup_duif_vs_filterpy": speedup,
        "table": table,
        "rmse_by_step_m": curves,
    }


def format_report(report: dict) -> str:
    """Human-readable tables of a :func:`run_benchmark` report."""
    lines = [
        f"estimation benchmark: {report['vehicles']} vehicles, {report['runs']} runs x {report['steps']} steps, "
        f"seed {report['seed']}",
        f"{'method':<14}{'RMSE m':>9}{'RMSE/sqrt(PCRLB)':>18}{'NEES':>8}{'us/step (median)':>18}",
    ]
    for name, m in report["methods"].items():
        lines.append(f"{name:<14}{m['rmse_m']:>9.3f}{m['rmse_over_pcrlb']:>18.4f}{m['nees']:>8.3f}{m['us_per_step_median']:>18.1f}")
    lines.extend(f"  {name}: {METHOD_NOTES[name]}" for name in report["methods"] if name in METHOD_NOTES)
    low, high = report["nees_band_95"]
    lines.append(f"NEES 95% band for {report['runs']} runs (n = 4): [{low:.3f}, {high:.3f}]")
    lines.append(f"DUIF speed-up over FilterPy UKF (median us/step ratio): {report['speedup_duif_vs_filterpy']:.1f}x")
    lines.append("")
    lines.append(f"{'vehicles':>8}{'DUIF us':>10}{'UKF us':>10}{'ratio':>8}{'DUIF RMSE':>11}{'UKF RMSE':>10}{'DUIF/PCRLB':>12}")
    for row in report["table"]:
        d, u = row["duif"], row["filterpy_ukf"]
        lines.append(
            f"{row['vehicles']:>8}{d['us_per_step_median']:>10.1f}{u['us_per_step_median']:>10.1f}"
            f"{u['us_per_step_median'] / d['us_per_step_median']:>7.1f}x{d['rmse_m']:>11.3f}{u['rmse_m']:>10.3f}"
            f"{d['rmse_over_pcrlb']:>12.4f}"
        )
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """Write the report as JSON (keys ``methods.<name>.{rmse_m, rmse_over_pcrlb, nees, us_per_step_median}``)."""
    path.write_text(json.dumps(report, indent=2) + "\n")


def write_plots(report: dict, directory: Path) -> list[Path]:
    """``estimation_rmse.png`` (RMSE by step against the PCRLB), ``estimation_speed.png`` (microseconds per
    step by vehicle count) and ``estimation.md`` (the tables)."""
    plt = pyplot()
    written: list[Path] = []
    curves = report["rmse_by_step_m"]
    fig, ax = plt.subplots(figsize=(9, 4))
    for name, metrics in report["methods"].items():
        ax.plot(curves[name], label=f"{name} (RMSE {metrics['rmse_m']:.2f} m)")
    ax.plot(curves["pcrlb_m"], "k--", linewidth=1.0, label="sqrt(PCRLB position trace)")
    ax.set_yscale("log")
    ax.set_xlabel("step")
    ax.set_ylabel(f"position RMSE over {report['runs']} runs (m)")
    ax.set_title(f"{report['vehicles']} vehicles, {report['runs']} runs, seed {report['seed']}", fontsize=10)
    ax.legend(fontsize=8)
    save(fig, directory, "estimation_rmse.png", written)

    fig, ax = plt.subplots(figsize=(7, 4))
    counts = [row["vehicles"] for row in report["table"]]
    for name in report["methods"]:
        ax.plot(counts, [row[name]["us_per_step_median"] for row in report["table"]], "o-", label=name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("vehicles")
    ax.set_ylabel("microseconds per predict + update (median)")
    ax.legend(fontsize=8)
    save(fig, directory, "estimation_speed.png", written)

    low, high = report["nees_band_95"]
    methods = [(name, m["rmse_m"], m["rmse_over_pcrlb"], m["nees"], m["us_per_step_median"])
               for name, m in report["methods"].items()]
    table = [(row["vehicles"], row["duif"]["us_per_step_median"], row["filterpy_ukf"]["us_per_step_median"],
              row["filterpy_ukf"]["us_per_step_median"] / row["duif"]["us_per_step_median"], row["duif"]["rmse_m"],
              row["filterpy_ukf"]["rmse_m"], row["duif"]["rmse_over_pcrlb"]) for row in report["table"]]
    write_markdown(directory, "estimation.md", "gcs-bench estimation: DUIF against FilterPy's UKF", [
        (f"{report['vehicles']} vehicles", ["method", "RMSE m", "RMSE / sqrt(PCRLB)", "NEES", "us/step (median)"],
         methods),
        ("By vehicle count", ["vehicles", "DUIF us/step", "UKF us/step", "UKF / DUIF", "DUIF RMSE m", "UKF RMSE m",
                              "DUIF RMSE / sqrt(PCRLB)"], table),
    ], [f"{report['runs']} runs x {report['steps']} steps, seed {report['seed']}; NEES 95% band "
        f"[{low:.3f}, {high:.3f}]; DUIF speed-up {report['speedup_duif_vs_filterpy']:.2f}x"], written)
    return written
