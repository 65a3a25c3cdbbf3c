"""The many-target benches through the engine: their scenes as the vehicles' messages, the engine's tracks back.

``gcs-bench multitarget`` and ``gcs-bench sharing`` (and ``scale``) run our many-target tracking as the
daemon does: a scenario with ``[multitarget]`` (:func:`many_target_scenario`: the bench's association,
detection probability, clutter and starvation time on the wang2012_urban city) drives
:class:`gcs.engine.engine.Engine` through :mod:`benchmarks.closed_loop`, and each step's scan is the
vehicles' ``SensorReport`` s, each listing its detections without identity, clutter among them.

* :class:`ScanScene`: the vehicles fly prescribed paths (``multitarget``'s fixed orbits) and report the
  scans made beforehand, the very scans Stone Soup's trackers are fed;
* :class:`SharingScene`: the vehicles are the loop's :class:`~benchmarks.closed_loop.IdealAirframes`; each
  step's scan is made from where they are (:func:`sim_vehicles.truth.detections.scan`), and which targets
  each one has in its field (range and sight, before the detection probability) is kept for the scores.

:func:`confirmed` reads a step's confirmed tracks back from what the engine published.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import msgspec
import numpy as np
from numpy.typing import NDArray

from benchmarks import multitarget as mt
from benchmarks.closed_loop import NS_PER_S, EngineLoop
from gcs.config import Scenario
from gcs.config.multitarget import MultiTargetConfig
from gcs.core.kinematics import VehicleState
from gcs.core.models.sensor import SensorModel
from gcs.core.multitarget.coverage import clutter_volume
from gcs.core.world import World
from protocols.keys import nav_key, report_key, truth_key
from protocols.messages import NavReport, SensorReport, TargetTruth
from sim_vehicles.scene import wire_measurement
from sim_vehicles.truth.detections import scan as detection_scan

__all__ = ["many_target_scenario", "ScanScene", "SharingScene", "confirmed"]


def many_target_scenario(base: Scenario, association: str, pd: float, clutter: float, vehicles: int,
                         starvation_s: float = 20.0, forget_s: float = 90.0, kind: str = "gaussian",
                         clutter_density: float | None = None) -> Scenario:
    """``base`` (its city, sensor and first ``vehicles`` UAVs) tracking every target: ``[multitarget]`` with the
    benches' tracker (:data:`benchmarks.multitarget.PROCESS_NOISE`, :data:`~benchmarks.multitarget.MAX_MISSED_SCANS`,
    :data:`~benchmarks.multitarget.MAX_POSITION_TRACE_M2`), its sensor's detection probability and clutter;
    ``kind`` the tracker (``gaussian``, ``road`` or ``auto``, :mod:`gcs.config.multitarget`). ``clutter_density``
    (false detections per m rad^2): the tracker's clutter density, given as the clutter rate the engine spreads
    over its measurement volume (:func:`gcs.core.multitarget.coverage.clutter_volume`); None: ``clutter``."""
    if clutter_density is not None:
        clutter = clutter_density * clutter_volume(base.sensor.max_range_m)
    sensor = msgspec.structs.replace(base.sensor, detection_probability=pd, clutter_rate=clutter)
    config = MultiTargetConfig(kind=kind, association=association, accel_psd_m2_s3=mt.PROCESS_NOISE,
                               max_misses=mt.MAX_MISSED_SCANS, max_position_trace_m2=mt.MAX_POSITION_TRACE_M2,
                               starvation_s=starvation_s, forget_s=forget_s)
    team = [msgspec.structs.replace(v, sensor=None) for v in base.vehicles[:vehicles]]
    return msgspec.structs.replace(base, sensor=sensor, vehicles=team, multitarget=config)


def confirmed(loop: EngineLoop, step: int) -> tuple[tuple[int, ...], NDArray[np.float64]]:
    """The confirmed tracks the engine published for ``step``: their ids and positions (m, 2)."""
    tracks = loop.tracks.get(round(step * loop.step_s * NS_PER_S), [])
    ids = tuple(int(t.target_id[1:]) for t in tracks)
    return ids, np.array([t.state[:2] for t in tracks], dtype=np.float64).reshape(-1, 2)


def _reports(roster: Sequence[str], stamp: int, step: int, xyz: NDArray[np.float64], headings: NDArray[np.float64],
             speeds: NDArray[np.float64], detections: Sequence[Sequence], sensor: SensorModel,
             truth_xy: NDArray[np.float64], step_s: float) -> list[tuple[str, object]]:
    """Every vehicle's nav report and sensor report, and every target's truth (its path ``truth_xy``, (steps, N, 2),
    at ``step``), at ``stamp``."""
    out: list[tuple[str, object]] = []
    for i, vehicle_id in enumerate(roster):
        heading = float(headings[i])
        velocity = (float(speeds[i] * math.cos(heading)), float(speeds[i] * math.sin(heading)), 0.0)
        out.append((nav_key(vehicle_id), NavReport(vehicle_id=vehicle_id, seq=step + 1, stamp_ns=stamp,
                                                   velocity_enu_mps=velocity, heading_rad=heading)))
    for i, vehicle_id in enumerate(roster):
        found = tuple(wire_measurement(sensor.components, np.asarray(d.values), sensor.std) for d in detections[i])
        out.append((report_key(vehicle_id), SensorReport(vehicle_id=vehicle_id, seq=step + 1, stamp_ns=stamp,
                                                         vehicle_position_enu_m=tuple(map(float, xyz[i])),
                                                         detections=found)))
    later = truth_xy[min(step + 1, len(truth_xy) - 1)] - truth_xy[step] if len(truth_xy) > 1 else 0.0 * truth_xy[0]
    for j, ((x, y), (vx, vy)) in enumerate(zip(truth_xy[step], later / step_s)):
        out.append((truth_key(f"target{j}"), TargetTruth(target_id=f"target{j}", seq=step + 1, stamp_ns=stamp,
                                                          position_enu_m=(float(x), float(y)),
                                                          velocity_enu_mps=(float(vx), float(vy)))))
    return out


def _headings(path: NDArray[np.float64], step: int) -> NDArray[np.float64]:
    """Each vehicle's heading along a prescribed path (steps, V, 3) at ``step``: toward its next point."""
    ahead, here = (path[step + 1], path[step]) if step + 1 < len(path) else (path[step], path[step - 1])
    return np.arctan2(ahead[:, 1] - here[:, 1], ahead[:, 0] - here[:, 0])


class ScanScene:
    """Prescribed flights and the scans made along them (:func:`benchmarks.multitarget.make_scans`)."""

    def __init__(self, roster: Sequence[str], scene: mt.Scene, scans: Sequence, sensor: SensorModel,
                 step_s: float) -> None:
        self.roster, self.scene, self.scans, self.sensor, self.step_s = list(roster), scene, scans, sensor, step_s
        path = scene.vehicle_xyz
        self.speeds = np.hypot(*(path[1] - path[0])[:, :2].T) / step_s

    def messages(self, step: int, substep: int, vehicles: VehicleState | None) -> list[tuple[str, object]]:
        if substep != 0:
            return []
        stamp, per_vehicle, _, _ = self.scans[step]
        detections = [per_vehicle.get(i, []) for i in range(len(self.roster))]
        return _reports(self.roster, stamp, step, self.scene.vehicle_xyz[step], _headings(self.scene.vehicle_xyz, step),
                        self.speeds, detections, self.sensor, self.scene.truth_xy, self.step_s)

    def flown(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        """The flights are prescribed."""


class SharingScene:
    """The targets' truths, scans from where the vehicles are (their draws from ``rng``), and their fields."""

    def __init__(self, roster: Sequence[str], world: World, scene: mt.Scene, sensor: SensorModel, max_range_m: float,
                 pd: float, clutter: float, rng: np.random.Generator, step_s: float,
                 prescribed: bool = False) -> None:
        self.roster, self.world, self.scene, self.sensor = list(roster), world, scene, sensor
        self.max_range_m, self.pd, self.clutter, self.rng, self.step_s = max_range_m, pd, clutter, rng, step_s
        self.prescribed = prescribed
        steps = len(scene.truth_xy)
        self.field = np.zeros((steps, len(self.roster), scene.truth_xy.shape[1]), dtype=bool)
        self.detections = 0

    def messages(self, step: int, substep: int, vehicles: VehicleState | None) -> list[tuple[str, object]]:
        if substep != 0:
            return []
        if self.prescribed or vehicles is None:
            path = self.scene.vehicle_xyz
            xyz, headings = path[step], _headings(path, step)
            speeds = np.hypot(*(path[1] - path[0])[:, :2].T) / self.step_s
        else:
            xyz, headings, speeds = vehicles.xyz, vehicles.heading, vehicles.speed
        truths = self.scene.truth_xy[step]
        field = mt.in_field(self.world, truths, xyz, self.sensor.target_height_m, self.max_range_m)
        self.field[step] = field
        result = detection_scan(truths, xyz, self.sensor, self.pd, self.clutter, self.max_range_m, self.rng, field)
        self.detections += sum(len(d) for d in result.detections)
        stamp = round(step * self.step_s * NS_PER_S)
        return _reports(self.roster, stamp, step, xyz, headings, speeds, result.detections, self.sensor,
                        self.scene.truth_xy, self.step_s)

    def flown(self, before: VehicleState, after: VehicleState, dt: float) -> None:
        """Nothing of the flight is simulated beyond where the vehicles are."""
