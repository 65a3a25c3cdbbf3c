"""``gcs-bench estimation``'s many-target part: N targets seen by the same UAVs, every target's update per step.

The scene: N targets (20 by default) start on a grid 400 m apart around (1500, 1500) m and
follow the white-noise-acceleration model of the one-target part, each on its own; V UAVs
(3) orbit the targets' centroid 2 km out at 25 m/s and 200, 210, 220 m, each measuring
every target with the one-target part's sensor. Each target is a "run" of an
:class:`~benchmarks.estimation.EstimationDataset` whose vehicles are the shared UAVs, so
its PCRLB and its FilterPy UKF are the one-target part's.

Methods, per step, all N targets:

* ``multitarget``: the daemon's many-target filter
  (:mod:`gcs.core.multitarget.filter`): the tracks predicted together, then per UAV the
  pairs that can pass the 99% gate (:mod:`gcs.core.multitarget.candidates`), their
  innovations, the gate, each track's own detection (the association known, as
  FilterPy is given it; one outside its gate is left out, as the daemon's association
  leaves it), and the summed information fused (eq. 14-15);
* ``duif``: the DUIF's iterated update of every target in one call
  (:func:`~gcs.core.filters.iterated.iterated_update_many`, the compiled kernel when numba
  is installed), after one prediction of them all;
* ``filterpy_ukf``: one FilterPy UKF per target.

The three run one after the other at each step, in a rotating order, each timed whole.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from benchmarks.estimation_methods import (
    ACCEL_PSD,
    SENSOR_STD,
    FilterRun,
    filterpy_stepper,
    observe,
    sensor_model,
)
from gcs.core.filters.iterated import iterated_update_many
from gcs.core.filters.uif import UnscentedInformationFilter
from gcs.core.models.motion import constant_velocity
from gcs.core.multitarget import filter as batched
from gcs.core.multitarget.candidates import candidate_pairs
from gcs.core.multitarget.gating import gate, gate_threshold

__all__ = ["generate_scene", "run_scene_methods", "SPACING_M", "ORBIT_M", "GATE_PROBABILITY"]

SPACING_M = 400.0
ORBIT_M = 2000.0
SPEED_MPS = 25.0
GATE_PROBABILITY = 0.99  # the many-target tracker's default


def generate_scene(runs: int, steps: int, targets: int, vehicles: int, seed: int, step_s: float = 1.0):
    """``runs`` scenes of ``targets`` targets as one data set of ``runs * targets`` target-runs (scene-major)."""
    from benchmarks.estimation import INITIAL_STD, EstimationDataset

    rng = np.random.default_rng(seed)
    f, q = constant_velocity(ACCEL_PSD).matrices(step_s)
    q_factor = np.linalg.cholesky(q)
    columns = int(np.ceil(np.sqrt(targets)))
    grid = SPACING_M * np.array([(i % columns, i // columns) for i in range(targets)], dtype=float)
    starts = np.column_stack([1500.0 + grid - grid.mean(axis=0), np.tile([5.0, 0.0], (targets, 1))])
    truth = np.empty((runs, targets, steps, 4))
    truth[:, :, 0] = starts
    for k in range(1, steps):
        truth[:, :, k] = truth[:, :, k - 1] @ f.T + rng.standard_normal((runs, targets, 4)) @ q_factor.T
    centre = truth[:, :, :, :2].mean(axis=1)  # (R, K, 2)
    phases = 2.0 * np.pi * np.arange(vehicles) / vehicles
    angles = phases[None, :] + (SPEED_MPS / ORBIT_M) * step_s * np.arange(steps)[:, None]  # (K, V)
    uav = np.empty((runs, steps, vehicles, 3))
    uav[..., 0] = centre[:, :, None, 0] + ORBIT_M * np.cos(angles)
    uav[..., 1] = centre[:, :, None, 1] + ORBIT_M * np.sin(angles)
    uav[..., 2] = 200.0 + 10.0 * np.arange(vehicles)
    vehicle_xyz = np.repeat(uav, targets, axis=0).reshape(runs * targets, steps, vehicles, 3)
    truth = truth.reshape(runs * targets, steps, 4)
    noise = rng.standard_normal(vehicle_xyz.shape) * np.asarray(SENSOR_STD)
    measurements = observe(truth[:, :, None, :2], vehicle_xyz) + noise
    measurements[..., 1] = np.angle(np.exp(1j * measurements[..., 1]))
    initial_cov = np.diag(np.square(INITIAL_STD))
    initial_mean = truth[:, 0] + rng.standard_normal((runs * targets, 4)) @ np.linalg.cholesky(initial_cov).T
    return EstimationDataset(step_s, truth, vehicle_xyz, measurements, initial_mean, initial_cov)


def _multitarget(data, scene: int, targets: int) -> Callable[[int], tuple[NDArray, NDArray]]:
    """The many-target filter over one scene's targets: ``step(k)`` returns means (N, 4), covariances (N, 4, 4)."""
    rows = slice(scene * targets, (scene + 1) * targets)
    motion = constant_velocity(ACCEL_PSD)
    sensor = sensor_model()
    gamma = gate_threshold(GATE_PROBABILITY, sensor.dim)
    _, _, vehicles = data.shape
    state = {"mean": data.initial_mean[rows].copy(), "cov": np.repeat(data.initial_cov[None], targets, axis=0)}
    own = np.arange(targets)
    exact = np.zeros((targets, 3, 3))

    def step(k: int) -> tuple[NDArray, NDArray]:
        mean, cov = state["mean"], state["cov"]
        if k > 0:
            mean, cov = batched.predict(mean, cov, data.step_s, motion)
        a_sum, b_sum = np.zeros((targets, 2, 2)), np.zeros((targets, 2))
        for v in range(vehicles):
            z, xyz = data.measurements[rows, k, v], data.vehicle_xyz[rows, k, v]
            pairs = candidate_pairs(mean, cov, sensor, z, xyz, exact, gamma)
            inn = batched.innovations(mean, cov, sensor, z, xyz, exact, pairs)
            valid = gate(inn.d2, GATE_PROBABILITY, sensor.dim)
            a, b = batched.assigned_contributions(inn, np.where(valid[own, own], own, -1))
            a_sum += a
            b_sum += b
        state["mean"], state["cov"] = batched.information_update(mean, cov, a_sum, b_sum)
        return state["mean"], state["cov"]

    return step


def _duif_many(data, scene: int, targets: int) -> Callable[[int], tuple[NDArray, NDArray]]:
    """The DUIF over one scene's targets, one call: ``step(k)`` returns means (N, 4), covariances (N, 4, 4)."""
    rows = slice(scene * targets, (scene + 1) * targets)
    uif = UnscentedInformationFilter(constant_velocity(ACCEL_PSD))
    sensor = sensor_model()
    state = {"mean": data.initial_mean[rows].copy(), "cov": np.repeat(data.initial_cov[None], targets, axis=0)}

    def step(k: int) -> tuple[NDArray, NDArray]:
        mean, cov = state["mean"], state["cov"]
        if k > 0:
            mean, cov = batched.predict(mean, cov, data.step_s, uif.motion)
        state["mean"], state["cov"] = iterated_update_many(uif, mean, cov, sensor, data.measurements[rows, k],
                                                           data.vehicle_xyz[rows, k])
        return state["mean"], state["cov"]

    return step


def run_scene_methods(data, targets: int, progress: Callable[[str], None] | None = None) -> dict[str, FilterRun]:
    """Every method on every scene, alternated step by step (rotating order); each FilterRun is per target-run,
    its ``step_seconds`` (scenes, K) the time of the whole scene's step."""
    from time import perf_counter

    total, steps, _ = data.shape
    scenes = total // targets
    names = ["multitarget", "duif", "filterpy_ukf"]
    means = {name: np.empty((total, steps, 4)) for name in names}
    covs = {name: np.empty((total, steps, 4, 4)) for name in names}
    seconds = {name: np.empty((scenes, steps)) for name in names}
    for scene in range(scenes):
        if progress is not None:
            progress(f"{targets} targets: scene {scene + 1}/{scenes}")
        members = range(scene * targets, (scene + 1) * targets)
        ukfs = [filterpy_stepper(data, r) for r in members]
        together = {"multitarget": _multitarget(data, scene, targets), "duif": _duif_many(data, scene, targets)}
        for k in range(steps):
            shift = (scene * steps + k) % len(names)
            for name in names[shift:] + names[:shift]:
                start = perf_counter()
                if name == "filterpy_ukf":
                    results = [ukf(k) for ukf in ukfs]
                else:
                    mean, cov = together[name](k)
                    results = list(zip(mean, cov))
                seconds[name][scene, k] = perf_counter() - start
                for offset, (m, c) in enumerate(results):
                    means[name][scene * targets + offset, k], covs[name][scene * targets + offset, k] = m, c
    return {name: FilterRun(means[name], covs[name], seconds[name]) for name in names}
