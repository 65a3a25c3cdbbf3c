"""``gcs-bench multitarget``: the runs of the many-target bench.

**Scene per seed** (:func:`make_scene`, every draw from ``numpy.random.default_rng(seed)``):
``targets`` street-following ground targets (:class:`~sim_vehicles.truth.target.StreetTarget`)
on the wang2012_urban city, starting at the intersections nearest uniform points of the
city. Targets 0 and 1 are a **side-by-side pair**: for the first ``joint_steps`` steps
target 1 is target 0 shifted by ``pair_offset_m`` perpendicular to target 0's velocity (to
its left), so both are on the same street and exactly that far apart; then target 1
drives on by itself, at ``pair_speed_ratio`` times the street speed, so the two separate.
Three UAVs fly fixed circular orbits over the city (:func:`orbits`; no planner: this
bench measures tracking) with the scenario's range/azimuth/elevation sensor and its
maximum range. A vehicle sees a target only with a line of sight past the buildings
(:meth:`gcs.core.world.World.line_of_sight`). Decision step 1 s.

**Methods**, fed identical scans (:func:`sim_vehicles.truth.detections.scan`), alternated scan by
scan (:mod:`benchmarks.multitarget_methods`): our multi-target tracker as the daemon runs it, the
engine (:class:`gcs.engine.engine.Engine` with ``[multitarget]``, :mod:`benchmarks.many_targets_loop`)
fed each scan as the vehicles' sensor reports, its confirmed tracks read from what it publishes:
``gnn_roads`` and ``jpda_roads`` the road tracker (``kind = "road"``, what ``auto`` runs in this
city; :mod:`gcs.core.multitarget.road_tracker`, its motion and seed ``[estimator.road]``'s
defaults), ``gnn`` and ``jpda`` the Gaussian tracker (``kind = "gaussian"``); and Stone Soup's GNN
and JPDA (:mod:`benchmarks.stonesoup_peer`) on the scans themselves, configured as ours: the same
coverage, M-of-N confirmation, deletion, gate, detection probability and clutter density
(:func:`clutter_density`). The wall time is measured here with ``time.perf_counter`` (never in the
core): for ours, the engine's whole decision step (the scan of
:class:`gcs.core.multitarget.MultiTargetTracker`, the confirmed tracks' k+1..k+n predictions and
their ``TrackEstimate`` s; the reports' decoding is not in it), for the peers their tracker's step.

**Scores** per run and method over the steps after ``warm_up`` (:func:`score_run`): mean
GOSPA (c = :data:`CUTOFF_M`, p = 2, alpha = 2) and OSPA (same c and p) of the confirmed
tracks' positions against the truths, and the track scores of
:func:`gcs.core.metrics.track_scores` (track breaks, id swaps, false tracks, missed truth-steps).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.config.multitarget import MultiTargetConfig
from gcs.core.metrics import StepTracks, gospa, ospa, track_scores
from gcs.core.models.sensor import ELEVATION, SensorModel
from gcs.core.multitarget.coverage import coverage, in_field, sight_matrix
from gcs.core.world import World
from sim_vehicles.truth.detections import scan as detection_scan
from sim_vehicles.truth.target import StreetTarget, TargetState

__all__ = ["CUTOFF_M", "ORDER_P", "ORBITS", "OURS", "PEERS", "BenchConfig", "Scene", "MethodRun", "orbits", "make_scene",
           "make_scans", "sight_matrix", "in_field", "coverage", "clutter_density", "clutter_density_at",
           "score_run"]

CUTOFF_M = 100.0
"""GOSPA / OSPA cut-off c, metres: twice the cross-range error of one 0.05 rad azimuth at 1 km."""
ORDER_P = 2.0
STEP_NS = 1_000_000_000
"""Decision step, 1 s."""
ORBITS = ((1000.0, 1000.0, 400.0), (2000.0, 1000.0, 400.0), (1500.0, 2000.0, 400.0))
"""Centre x, centre y and radius (m) of each UAV's orbit; speed 25 m/s, the scenario's altitudes."""
ORBIT_SPEED_MPS = 25.0
RING_RADIUS_M = 1000.0
"""Distance from the city's centre (1500, 1500) of the orbits of UAVs beyond :data:`ORBITS`."""
OURS = ("gnn", "jpda", "gnn_roads", "jpda_roads")
PEERS = ("stonesoup_gnn", "stonesoup_jpda")
PROCESS_NOISE = 2.0
"""White-acceleration density (m^2/s^3) of every method's constant-velocity model: the street
targets turn at right angles at 10 m/s."""
MAX_MISSED_SCANS = 5
"""Consecutive scans in which some UAV covered a track and none detected it that delete it, for every method."""
CONFIRM_M, CONFIRM_N = MultiTargetConfig().confirm_m, MultiTargetConfig().confirm_n
"""Every method confirms a track detected on M of the last N scans (``[multitarget]``'s defaults)."""
GATE_PROBABILITY = MultiTargetConfig().gate_probability
"""Every method's chi-square gate probability, in the 3 dimensions of (range, azimuth, elevation)."""
MAX_POSITION_TRACE_M2 = 2.0e4
"""Trace of a track's (x, y) covariance above which every method deletes it (100 m per axis)."""


def orbits(count: int) -> tuple[tuple[float, float, float], ...]:
    """Centre x, centre y and radius of ``count`` UAVs' orbits: :data:`ORBITS`, then more spread on a ring."""
    extra = tuple((1500.0 + RING_RADIUS_M * math.cos(2.0 * math.pi * i / count),
                   1500.0 + RING_RADIUS_M * math.sin(2.0 * math.pi * i / count), 400.0)
                  for i in range(len(ORBITS), count))
    return (ORBITS + extra)[:count]


@dataclass(frozen=True)
class BenchConfig:
    """What one run is made of (the command's options)."""

    targets: int = 5
    steps: int = 120
    pd: float = 0.9
    clutter: float = 2.0
    pair_offset_m: float = 7.0
    joint_fraction: float = 0.4
    pair_speed_ratio: float = 0.6
    warm_up: int = 10

    @property
    def joint_steps(self) -> int:
        """Steps during which the pair drives side by side."""
        return max(1, int(round(self.joint_fraction * self.steps)))


@dataclass(frozen=True)
class Scene:
    """Truth positions (steps, N, 2) and UAV positions (steps, V, 3), ENU metres, at steps 0, 1 s, ..."""

    truth_xy: NDArray[np.float64]
    vehicle_xyz: NDArray[np.float64]
    joint_steps: int


@dataclass(frozen=True)
class MethodRun:
    """One method over one run: per step the confirmed tracks' ids and positions (m, 2), and the scan times (s)."""

    track_ids: tuple[tuple, ...]
    track_xy: tuple[NDArray[np.float64], ...]
    seconds: tuple[float, ...]


def _left(velocity: NDArray[np.float64]) -> NDArray[np.float64]:
    """The unit vector 90 degrees counter-clockwise from ``velocity``."""
    return np.array([-velocity[1], velocity[0]]) / np.hypot(*velocity)


def make_scene(world: World, altitudes_m: Sequence[float], config: BenchConfig, rng: np.random.Generator) -> Scene:
    """The truths and the UAVs of one run (see the module docstring)."""
    if world.streets is None:
        raise ValueError("the multitarget bench needs a generated city with streets")
    streets = world.streets
    model = StreetTarget(streets.xs, streets.ys)
    partner = StreetTarget(streets.xs, streets.ys, speed_mps=model.speed_mps * config.pair_speed_ratio)
    size = np.array(world.size_m)
    states = [model.start(rng.uniform(0.2, 0.8) * size, rng) for _ in range(config.targets)]
    pair = config.targets >= 2
    truth = np.zeros((config.steps, config.targets, 2))
    for k in range(config.steps):
        if pair and k < config.joint_steps:  # target 1 rides beside target 0
            lead = states[0]
            states[1] = TargetState(lead.position + config.pair_offset_m * _left(lead.velocity), lead.velocity.copy(),
                                    lead.elapsed_s)
        truth[k] = [s.position for s in states]
        states = [(partner if pair and j == 1 else model).step(s, 1.0, rng) for j, s in enumerate(states)]
    t = np.arange(config.steps, dtype=np.float64)
    uavs = []
    for (cx, cy, radius), alt in zip(orbits(len(altitudes_m)), altitudes_m):
        phase = rng.uniform(-math.pi, math.pi) + t * ORBIT_SPEED_MPS / radius
        uavs.append(np.column_stack([cx + radius * np.cos(phase), cy + radius * np.sin(phase), np.full_like(t, alt)]))
    return Scene(truth, np.stack(uavs, axis=1), config.joint_steps)


def make_scans(world: World, scene: Scene, sensor: SensorModel, max_range_m: float, config: BenchConfig,
               rng: np.random.Generator) -> list[tuple[int, dict[int, list], SensorModel, Callable]]:
    """Every step's detections by vehicle, with line of sight past the buildings.

    Each scan is ``(stamp_ns, {v: [...]}, sensor, in_view)``, ``in_view`` the UAVs'
    coverage at that step (:func:`coverage`) for our trackers' miss count."""
    scans = []
    for k in range(len(scene.truth_xy)):
        truths, vehicles = scene.truth_xy[k], scene.vehicle_xyz[k]
        visible = sight_matrix(world, truths, vehicles, sensor.target_height_m)
        result = detection_scan(truths, vehicles, sensor, config.pd, config.clutter, max_range_m, rng, visible)
        scans.append((k * STEP_NS, dict(enumerate(result.detections)), sensor,
                      coverage(world, vehicles, sensor.target_height_m, max_range_m)))
    return scans


def clutter_density(world: World, scene: Scene, sensor: SensorModel, max_range_m: float, rate: float) -> float:
    """False detections per m rad^2 of (range, azimuth, elevation) where the targets are seen, for every method.

    The simulator draws ``rate`` clutter points per UAV and scan uniformly over the ground
    disc of radius ``R_h`` within slant range (:mod:`sim_vehicles.truth.clutter`), density
    ``rate / (pi R_h^2)`` per m^2. A ground point at slant range ``rho`` from a UAV at
    height ``dz`` above it has horizontal range ``r_h = sqrt(rho^2 - dz^2)``, and
    ``r_h dr_h = rho drho``, so per m of slant range and rad of azimuth the density is
    ``rate rho / (pi R_h^2)``; the ground points lie on one elevation per range, spread by
    the elevation noise ``sigma_theta`` (the range noise adds nothing at these ranges), so
    on that surface the density per m rad^2 is

    .. math:: \\lambda(\\rho) = \\frac{\\text{rate}\\; \\rho}{\\pi R_h^2 \\sqrt{2 \\pi}\\, \\sigma_\\theta}

    evaluated at ``rho``, the median slant range of the truths in some UAV's field
    (:func:`in_field`) over the scene."""
    height = sensor.target_height_m
    ranges = []
    for truths, vehicles in zip(scene.truth_xy, scene.vehicle_xyz):
        field = in_field(world, truths, vehicles, height, max_range_m)
        slant = np.sqrt(((truths[None] - vehicles[:, None, :2]) ** 2).sum(-1) + (vehicles[:, None, 2] - height) ** 2)
        ranges.append(slant[field])
    rho = float(np.median(np.concatenate(ranges))) if any(r.size for r in ranges) else max_range_m / 2.0
    sigma = float(np.sqrt(sensor.noise_variance(np.array([rho, 0.0, 0.0]))[sensor.components.index(ELEVATION)]))
    return clutter_density_at(rho, rate, max_range_m, float(np.mean(scene.vehicle_xyz[..., 2])) - height, sigma)


def clutter_density_at(rho_m: float, rate: float, max_range_m: float, dz_m: float, sigma_theta_rad: float) -> float:
    """``lambda(rho)`` of :func:`clutter_density`: per m rad^2 at slant range ``rho_m`` from a UAV ``dz_m`` above
    the ground, ``rate`` clutter points a scan, elevation noise ``sigma_theta_rad``."""
    disc_m2 = math.pi * (max_range_m**2 - dz_m * dz_m)
    return rate * rho_m / (disc_m2 * math.sqrt(2.0 * math.pi) * sigma_theta_rad)


def score_run(run: MethodRun, truth_xy: NDArray[np.float64], warm_up: int) -> dict[str, float]:
    """Mean GOSPA and OSPA after the warm-up, the track scores over those steps, the median scan time (ms)."""
    steps = range(min(warm_up, len(truth_xy) - 1), len(truth_xy))
    truth_ids = list(range(truth_xy.shape[1]))
    gospas = [gospa(run.track_xy[k], truth_xy[k], CUTOFF_M, ORDER_P).distance for k in steps]
    ospas = [ospa(run.track_xy[k], truth_xy[k], CUTOFF_M, ORDER_P) for k in steps]
    scores = track_scores([StepTracks(truth_ids, truth_xy[k], list(run.track_ids[k]), run.track_xy[k])
                           for k in steps], CUTOFF_M, ORDER_P)
    return {"gospa": float(np.mean(gospas)), "ospa": float(np.mean(ospas)), "track_breaks": scores.track_breaks,
            "false_tracks": scores.false_tracks, "id_swaps": scores.id_swaps, "missed": scores.missed,
            "ms_per_scan": 1e3 * float(np.median(run.seconds))}
