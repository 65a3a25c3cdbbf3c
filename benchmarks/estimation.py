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

* ``duif``: the update the daemon runs, :func:`gcs.core.filters.iterated.iterated_update`
  after the prediction (the compiled kernel when numba is installed; second-order ``R``;
  linearised again while the posterior moves far), every vehicle's contribution on its
  own, fused by summation (eq. 14-15);
* ``duif_numpy``: the same update in its numpy form (what runs without numba);
* ``duif_eq13``: eq. (12)-(13) as printed (``second_order=False``), one linearisation;
* ``filterpy_ukf``: ``filterpy.kalman.UnscentedKalmanFilter`` with all
  vehicles' measurements stacked into one 3V vector, the same sigma points
  (alpha 1, beta 2, kappa 3 - n), azimuth residuals wrapped and azimuth
  means taken on the circle. Its sigma points are redrawn from the predicted
  ``(x, P)`` before each update: FilterPy otherwise reuses the propagated
  points, which miss ``Q`` (and are all zero before the first prediction).

Reported per method: position RMSE over all runs and steps, its ratio to the
square root of the mean PCRLB position trace, the average NEES of the full
state (its 95% band for the number of runs is printed beside it), and the
wall-clock microseconds of one predict + update step, median and interquartile
range. The methods run alternately, step by step (:func:`benchmarks.estimation_methods.run_methods`),
so machine noise hits all alike; the speed-up over FilterPy is given as the median and
interquartile range of the step-by-step ratios (FilterPy's step over the method's, same run
and step). A second part does the same for 20 targets seen by the same 3 UAVs
(:mod:`benchmarks.estimation_many`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from benchmarks.estimation_methods import (
    ACCEL_PSD,
    SENSOR_STD,
    FilterRun,
    Stepper,
    duif_eq13_stepper,
    duif_numpy_stepper,
    duif_stepper,
    filterpy_stepper,
    observe,
    run_methods,
    sensor_model,
)
from benchmarks.plots import pyplot, save, write_markdown
from gcs.core.filters.iterated import kernel_available
from gcs.core.models.motion import constant_velocity
from gcs.core.pcrlb import pcrlb

__all__ = ["EstimationDataset", "generate_dataset", "evaluate", "run_benchmark", "write_plots", "METHOD_NOTES",
           "METHODS", "position_bound", "nees_band", "run_methods"]

ORBIT_RADIUS_M = 300.0
SPEED_MPS = 25.0
INITIAL_STD = (50.0, 50.0, 10.0, 10.0)
MANY_TARGETS = 20


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
    measurements = observe(truth[:, :, None, :2], vehicle_xyz) + noise
    measurements[..., 1] = np.angle(np.exp(1j * measurements[..., 1]))
    initial_mean = start + rng.standard_normal((runs, 4)) @ np.linalg.cholesky(initial_cov).T
    return EstimationDataset(step_s, truth, vehicle_xyz, measurements, initial_mean, initial_cov)


METHOD_NOTES = {"duif": "the daemon's update: iterated_update after the prediction (second-order R, "
                        "the compiled kernel when numba is installed)",
                "duif_numpy": "the same update in its numpy form (without numba)",
                "duif_eq13": "eq. (12)-(13) as printed (second_order=False), one linearisation, numpy",
                "filterpy_ukf": "FilterPy's UnscentedKalmanFilter, every vehicle stacked",
                "multitarget": "the daemon's many-target filter (EKF, the gate's pairs, association known), "
                               "all targets in one call",
                "duif_many": "the DUIF's iterated update of all targets in one call (iterated_update_many)"}
"""What each method is, printed under the tables."""
METHODS: dict[str, Stepper] = {
    "duif": duif_stepper,
    "duif_numpy": duif_numpy_stepper,
    "duif_eq13": duif_eq13_stepper,
    "filterpy_ukf": filterpy_stepper,
}


def position_bound(data: EstimationDataset) -> NDArray[np.float64]:
    """PCRLB position trace at each step, averaged over the runs' true trajectories, shape (K,)."""
    _, steps, vehicles = data.shape
    bounds = pcrlb(
        constant_velocity(ACCEL_PSD), data.step_s, data.initial_cov, [sensor_model()] * vehicles,
        data.vehicle_xyz, np.ones((steps, vehicles), dtype=bool), data.truth,
    )
    return np.trace(bounds[:, :2, :2], axis1=1, axis2=2)


def evaluate(data: EstimationDataset, result: FilterRun, bound_trace: NDArray[np.float64]) -> dict[str, float]:
    """RMSE, RMSE / sqrt(PCRLB), average NEES and microseconds per step (median, quartiles)."""
    errors = result.means - data.truth
    squared = np.sum(errors[..., :2] ** 2, axis=-1)
    nees = np.einsum("rki,rki->rk", errors, np.linalg.solve(result.covs, errors[..., None])[..., 0])
    rmse = float(np.sqrt(squared.mean()))
    return {
        "rmse_m": rmse,
        "rmse_over_pcrlb": rmse / float(np.sqrt(bound_trace.mean())),
        "nees": float(nees.mean()),
        **quartiles("us_per_step", 1e6 * result.step_seconds),
    }


def quartiles(key: str, values: NDArray[np.float64]) -> dict[str, float]:
    """``{key}_median``, ``{key}_q25`` and ``{key}_q75`` of ``values``."""
    q25, median, q75 = np.percentile(values, [25, 50, 75])
    return {f"{key}_median": float(median), f"{key}_q25": float(q25), f"{key}_q75": float(q75)}


def speedups(results: dict[str, FilterRun], reference: str = "filterpy_ukf") -> dict[str, dict[str, float]]:
    """Per method, the step-by-step ratio of ``reference``'s time to its own (same run and step), quartiles."""
    base = results[reference].step_seconds
    return {name: quartiles("ratio", base / r.step_seconds) for name, r in results.items() if name != reference}


def rmse_by_step(data: EstimationDataset, result: FilterRun) -> list[float]:
    """Position RMSE over the runs at each step (m), shape (K,)."""
    squared = np.sum((result.means - data.truth)[..., :2] ** 2, axis=-1)
    return [float(x) for x in np.sqrt(squared.mean(axis=0))]


def nees_band(runs: int, dim: int = 4) -> tuple[float, float]:
    """Two-sided 95% band of the run-averaged NEES of a consistent filter (chi-square, R n dof)."""
    low, high = chi2.ppf([0.025, 0.975], runs * dim) / runs
    return float(low), float(high)


def run_benchmark(runs: int, seed: int, steps: int = 100, vehicle_counts: tuple[int, ...] = (1, 3, 10, 30),
                  table_runs: int = 5, scenes: int = 5, progress: Callable[[str], None] | None = None) -> dict:
    """The whole benchmark: the 3-vehicle comparison over ``runs`` runs, a table over vehicle counts, and
    ``scenes`` scenes of :data:`MANY_TARGETS` targets."""
    from benchmarks.estimation_many import generate_scene, run_scene_methods

    say = progress or (lambda _msg: None)
    say(f"3 vehicles: {runs} runs x {steps} steps (compiled kernel: {kernel_available()})")
    warm_up(generate_dataset(1, 3, 3, seed))
    data = generate_dataset(runs, steps, 3, seed)
    bound = position_bound(data)
    results = run_methods(data, METHODS, progress=say)
    methods = {name: evaluate(data, result, bound) for name, result in results.items()}
    curves = {"pcrlb_m": [float(x) for x in np.sqrt(bound)],
              **{name: rmse_by_step(data, result) for name, result in results.items()}}
    table = []
    for count in vehicle_counts:
        say(f"table: {count} vehicles, {table_runs} runs")
        small = generate_dataset(table_runs, steps, count, seed + count)
        small_bound = position_bound(small)
        row = {name: evaluate(small, result, small_bound) for name, result in run_methods(small, METHODS).items()}
        table.append({"vehicles": count, **row})
    scene = generate_scene(scenes, steps, MANY_TARGETS, 3, seed + 1000)
    many = run_scene_methods(scene, MANY_TARGETS, progress=say)
    many = {("duif_many" if name == "duif" else name): result for name, result in many.items()}
    scene_bound = position_bound(scene)
    return {
        "runs": runs, "steps": steps, "seed": seed, "vehicles": 3, "compiled_kernel": kernel_available(),
        "nees_band_95": nees_band(runs),
        "methods": methods,
        "speedup_vs_filterpy": speedups(results),
        "table": table,
        "rmse_by_step_m": curves,
        "many": {"targets": MANY_TARGETS, "scenes": scenes, "seed": seed + 1000, "nees_band_95": nees_band(
            scenes * MANY_TARGETS), "methods": {name: evaluate(scene, r, scene_bound) for name, r in many.items()},
                 "speedup_vs_filterpy": speedups(many)},
    }


def warm_up(data: EstimationDataset) -> None:
    """Run every method once, untimed: the kernel compiles and the imports load before any figure is taken."""
    run_methods(data, METHODS)


def _method_lines(methods: dict, speedup: dict) -> list[str]:
    lines = [f"{'method':<14}{'RMSE m':>9}{'RMSE/sqrt(PCRLB)':>18}{'NEES':>8}{'us/step median [IQR]':>26}"
             f"{'FilterPy / it, median [IQR]':>30}"]
    for name, m in methods.items():
        ratio = speedup.get(name)
        ratio_text = "-" if ratio is None else \
            f"{ratio['ratio_median']:.1f}x [{ratio['ratio_q25']:.1f}-{ratio['ratio_q75']:.1f}]"
        lines.append(f"{name:<14}{m['rmse_m']:>9.3f}{m['rmse_over_pcrlb']:>18.4f}{m['nees']:>8.3f}"
                     f"{m['us_per_step_median']:>12.1f} [{m['us_per_step_q25']:.1f}-{m['us_per_step_q75']:.1f}]"
                     f"{ratio_text:>30}")
    lines.extend(f"  {name}: {METHOD_NOTES[name]}" for name in methods if name in METHOD_NOTES)
    return lines


def format_report(report: dict) -> str:
    """Human-readable tables of a :func:`run_benchmark` report."""
    kernel = "compiled kernel (numba)" if report["compiled_kernel"] else "numpy form (numba not installed)"
    lines = [f"estimation benchmark: {report['vehicles']} vehicles, {report['runs']} runs x {report['steps']} steps, "
             f"seed {report['seed']}; the daemon's update runs the {kernel}; methods alternated step by step"]
    lines += _method_lines(report["methods"], report["speedup_vs_filterpy"])
    low, high = report["nees_band_95"]
    lines.append(f"NEES 95% band for {report['runs']} runs (n = 4): [{low:.3f}, {high:.3f}]")
    duif = report["speedup_vs_filterpy"]["duif"]
    lines.append(f"DUIF speed-up over FilterPy UKF (step-by-step ratio, median): {duif['ratio_median']:.1f}x")
    lines.append("")
    lines.append(f"{'vehicles':>8}{'DUIF us':>10}{'UKF us':>10}{'ratio':>8}{'DUIF RMSE':>11}{'UKF RMSE':>10}{'DUIF/PCRLB':>12}")
    for row in report["table"]:
        d, u = row["duif"], row["filterpy_ukf"]
        lines.append(
            f"{row['vehicles']:>8}{d['us_per_step_median']:>10.1f}{u['us_per_step_median']:>10.1f}"
            f"{u['us_per_step_median'] / d['us_per_step_median']:>7.1f}x{d['rmse_m']:>11.3f}{u['rmse_m']:>10.3f}"
            f"{d['rmse_over_pcrlb']:>12.4f}"
        )
    many = report["many"]
    lines += ["", f"{many['targets']} targets seen by the same 3 UAVs: {many['scenes']} scenes x {report['steps']} "
              f"steps, seed {many['seed']}; us per step for all {many['targets']} targets"]
    lines += _method_lines(many["methods"], many["speedup_vs_filterpy"])
    low, high = many["nees_band_95"]
    lines.append(f"NEES 95% band for {many['scenes'] * many['targets']} target-runs: [{low:.3f}, {high:.3f}]")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """Write the report as JSON (keys ``methods.<name>.{rmse_m, rmse_over_pcrlb, nees, us_per_step_median,
    us_per_step_q25, us_per_step_q75}``, ``speedup_vs_filterpy.<name>.ratio_{median, q25, q75}``, and the same
    under ``many``)."""
    path.write_text(json.dumps(report, indent=2) + "\n")


def _markdown_rows(methods: dict, speedup: dict) -> list[tuple]:
    rows = []
    for name, m in methods.items():
        ratio = speedup.get(name, {"ratio_median": float("nan"), "ratio_q25": float("nan"),
                                   "ratio_q75": float("nan")})
        rows.append((name, m["rmse_m"], m["rmse_over_pcrlb"], m["nees"], m["us_per_step_median"], m["us_per_step_q25"],
                     m["us_per_step_q75"], ratio["ratio_median"], ratio["ratio_q25"], ratio["ratio_q75"]))
    return rows


METHOD_COLUMNS = ["method", "RMSE m", "RMSE / sqrt(PCRLB)", "NEES", "us/step median", "us/step q25", "us/step q75",
                  "FilterPy / it median", "q25", "q75"]


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
    table = [(row["vehicles"], row["duif"]["us_per_step_median"], row["filterpy_ukf"]["us_per_step_median"],
              row["filterpy_ukf"]["us_per_step_median"] / row["duif"]["us_per_step_median"], row["duif"]["rmse_m"],
              row["filterpy_ukf"]["rmse_m"], row["duif"]["rmse_over_pcrlb"]) for row in report["table"]]
    many = report["many"]
    write_markdown(directory, "estimation.md", "gcs-bench estimation: DUIF against FilterPy's UKF", [
        (f"{report['vehicles']} vehicles", METHOD_COLUMNS,
         _markdown_rows(report["methods"], report["speedup_vs_filterpy"])),
        ("By vehicle count", ["vehicles", "DUIF us/step", "UKF us/step", "UKF / DUIF", "DUIF RMSE m", "UKF RMSE m",
                              "DUIF RMSE / sqrt(PCRLB)"], table),
        (f"{many['targets']} targets", METHOD_COLUMNS, _markdown_rows(many["methods"], many["speedup_vs_filterpy"])),
    ], [f"{report['runs']} runs x {report['steps']} steps, seed {report['seed']}; NEES 95% band "
        f"[{low:.3f}, {high:.3f}]; DUIF speed-up {report['speedup_vs_filterpy']['duif']['ratio_median']:.2f}x "
        "(step-by-step ratio, median)"], written)
    return written
