"""``gcs-bench imm``: the CV + coordinated-turn IMM against the single-model DUIF on the street-following target.

Data (the same for both filters, so every run is paired): the scenario's city and
its street-following target (:class:`sim_vehicles.truth.target.StreetTarget`:
10 m/s along the street grid, a 90 deg turn at half the intersections, so the
velocity jumps); three UAVs circle the *true* target at 300 m, 25 m/s, 120 deg
apart, at the scenario's altitudes, so that their paths do not depend on either
filter; every UAV's sensor (:class:`sim_vehicles.truth.sensor.TargetSensor`, the
scenario's noise and range) sees the target unless a building blocks the line of
sight. Both filters run through :func:`gcs.core.tracker.fuse`, started from the
same first detection: the scenario's ``duif`` (white acceleration 1.96 m^2/s^3, the
paper's) and the ``imm`` estimator kind with :data:`IMM_SETTINGS` (a quiet CV mode of
0.05 m^2/s^3 and a CT mode of 2 m^2/s^3; chosen on seeds 2012-2015, four runs,
against a grid of 16; the benchmark's default seeds start at 3000).

Reported per filter: position and velocity RMSE over every run and step with a
track, the RMSE in the 5 s after each turn of the target, the mean NEES of
``[x, y, vx, vy]`` (4 if consistent; its 99.9% band for the number of runs), and
the median microseconds of one fusion step; paired: in how many runs the IMM's
position RMSE was below the DUIF's, and the Wilcoxon signed-rank p-value.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import msgspec
import numpy as np
from scipy.stats import chi2, wilcoxon

from gcs.config import Scenario
from gcs.core.filters.uif import NS_PER_S
from gcs.core.tracker import Detection, fuse
from gcs.core.world import World
from gcs.engine.tracker_factory import tracker_config
from sim_vehicles.truth.sensor import TargetSensor
from sim_vehicles.truth.target import start_state, target_model

__all__ = ["FILTERS", "IMM_SETTINGS", "run_benchmark", "format_report", "write_json"]

FILTERS = ("duif", "imm")
IMM_SETTINGS = {"accel_psd_m2_s3": 0.05, "turn_accel_psd_m2_s3": 2.0, "turn_rate_psd_rad2_s3": 0.01,
                "initial_turn_rate_std_rad_s": 0.3, "mode_switch_probability": 0.05}
"""The IMM's estimator fields in the benchmark (the DUIF keeps the scenario's)."""
ORBIT_RADIUS_M = 300.0
ORBIT_SPEED_MPS = 25.0
AFTER_TURN_S = 5


def _data(scenario: Scenario, world: World, seed: int, steps: int):
    """Truth (K, 4), turn flags (K,) and the detections of every step."""
    rng_truth, rng_sensor = np.random.default_rng([seed, 1]), np.random.default_rng([seed, 2])
    model = target_model(scenario, world, "streets")
    target = start_state(model, scenario, rng_truth)
    sensors = [TargetSensor.from_config(scenario.sensor_for(v)) for v in scenario.vehicles]
    altitudes = np.array([v.altitude_m for v in scenario.vehicles])
    phases = 2.0 * np.pi * np.arange(len(sensors)) / len(sensors)
    dt = scenario.time.step_s
    truth, turned, detections = np.zeros((steps, 4)), np.zeros(steps, dtype=bool), []
    for k in range(steps):
        if k > 0:
            before = target.velocity
            target = model.step(target, dt, rng_truth)
            turned[k] = float(before @ target.velocity) < 0.5 * float(before @ before)
        truth[k] = target.vector
        angles = phases + ORBIT_SPEED_MPS / ORBIT_RADIUS_M * k * dt
        xyz = np.column_stack([target.position[0] + ORBIT_RADIUS_M * np.cos(angles),
                               target.position[1] + ORBIT_RADIUS_M * np.sin(angles), altitudes])
        target_xyz = np.array([target.position[0], target.position[1], 0.0])
        step = []
        for i, sensor in enumerate(sensors):
            obs = sensor.observe(target_xyz, xyz[i:i + 1], world.line_of_sight, rng_sensor)
            if obs.detected[0]:
                step.append(Detection(i, xyz[i], obs.values[0]))
        detections.append(tuple(step))
    return truth, turned, detections


def run_benchmark(scenario: Scenario, world: World, runs: int, seed: int, steps: int,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Both filters on ``runs`` paired runs of ``steps`` decision steps; the report as a dict."""
    say = progress or (lambda _msg: None)
    estimators = {"duif": msgspec.structs.replace(scenario.estimator, kind="duif", model="cv2d"),
                  "imm": msgspec.structs.replace(scenario.estimator, kind="imm", model="cv2d", **IMM_SETTINGS)}
    configs = {kind: tracker_config(msgspec.structs.replace(scenario, estimator=estimators[kind]), None, "orbit")
               for kind in FILTERS}
    step_ns = int(round(scenario.time.step_s * NS_PER_S))
    errors = {f: np.full((runs, steps, 4), np.nan) for f in FILTERS}
    nees = {f: np.full((runs, steps), np.nan) for f in FILTERS}
    times = {f: [] for f in FILTERS}
    after_turn = np.zeros((runs, steps), dtype=bool)
    for run in range(runs):
        truth, turned, detections = _data(scenario, world, seed + run, steps)
        for k in np.flatnonzero(turned):
            after_turn[run, k:k + AFTER_TURN_S] = True
        for name, config in configs.items():
            estimate = None
            for k in range(steps):
                start = time.perf_counter()
                estimate = fuse(config, estimate, k * step_ns, detections[k])
                times[name].append(time.perf_counter() - start)
                if estimate is not None:
                    e = estimate.mean - truth[k]
                    errors[name][run, k] = e
                    nees[name][run, k] = e @ np.linalg.solve(estimate.cov, e)
        say(f"run {run + 1}/{runs}: position RMSE duif {_rms(errors['duif'][run, :, :2]):.2f} m, "
            f"imm {_rms(errors['imm'][run, :, :2]):.2f} m")
    lo, hi = chi2.ppf([0.0005, 0.9995], 4 * runs) / runs
    report = {"scenario": scenario.name, "runs": runs, "seed": seed, "steps": steps, "nees_band": [lo, hi],
              "filters": {}}
    for name in FILTERS:
        e = errors[name]
        report["filters"][name] = {
            "rmse_m": _rms(e[..., :2]), "rmse_velocity_mps": _rms(e[..., 2:]),
            "rmse_after_turn_m": _rms(e[after_turn][:, :2]), "rmse_straight_m": _rms(e[~after_turn][:, :2]),
            "nees": float(np.nanmean(nees[name])), "us_per_step_median": float(np.median(times[name]) * 1e6),
        }
    per_run = {name: np.array([_rms(errors[name][r, :, :2]) for r in range(runs)]) for name in FILTERS}
    better = int(np.sum(per_run["imm"] < per_run["duif"]))
    differ = per_run["imm"] != per_run["duif"]
    p = float(wilcoxon(per_run["imm"][differ], per_run["duif"][differ]).pvalue) if differ.sum() >= 2 else float("nan")
    report["paired"] = {"imm_better_runs": better, "wilcoxon_p": p}
    return report


def _rms(values: np.ndarray) -> float:
    values = values[np.isfinite(values).all(axis=-1)] if values.ndim > 1 else values[np.isfinite(values)]
    return float(np.sqrt(np.mean(np.sum(values**2, axis=-1)))) if values.size else float("nan")


def format_report(report: dict) -> str:
    """The comparison as text."""
    lo, hi = report["nees_band"]
    lines = [f"imm benchmark: {report['scenario']}, street-following target, {report['runs']} paired runs of "
             f"{report['steps']} steps from seed {report['seed']}",
             f"{'filter':<7}{'RMSE m':>9}{'vel RMSE m/s':>14}{'after turns m':>15}{'straight m':>12}"
             f"{'NEES':>8}{'us/step':>10}"]
    for name, m in report["filters"].items():
        lines.append(f"{name:<7}{m['rmse_m']:>9.2f}{m['rmse_velocity_mps']:>14.2f}{m['rmse_after_turn_m']:>15.2f}"
                     f"{m['rmse_straight_m']:>12.2f}{m['nees']:>8.2f}{m['us_per_step_median']:>10.0f}")
    paired = report["paired"]
    lines.append(f"NEES band (4 states, 99.9%): {lo:.2f}-{hi:.2f}; IMM below DUIF in {paired['imm_better_runs']} of "
                 f"{report['runs']} runs, Wilcoxon p = {paired['wilcoxon_p']:.2g}")
    return "\n".join(lines)


def write_json(report: dict, path: Path) -> None:
    """JSON with ``filters.<duif|imm>.{rmse_m, rmse_velocity_mps, rmse_after_turn_m, nees, ...}`` and ``paired``."""
    path.write_text(json.dumps(report, indent=2) + "\n")
