"""``gcs-bench multitarget``: every method over the same scans, alternated scan by scan.

Each method keeps its own state and is stepped one scan at a time: scan ``k`` of every
method, then scan ``k + 1``, the order of the methods rotated by one each scan (method
``i`` goes ``(i + k) mod M``-th). A change in the machine's load during a run then lands on
every method alike, and the per-scan times of two methods on the same scan are paired.

* ours (:class:`OurStepper`): the engine with ``[multitarget]``
  (:mod:`benchmarks.many_targets_loop`), one decision step of :func:`benchmarks.closed_loop.fly_step`
  per scan; its time is the engine's decision step (``EngineLoop.tick_seconds``);
* Stone Soup's (:class:`PeerStepper`): :func:`benchmarks.stonesoup_peer.scan_peer` per scan, its time
  that of the tracker's sets and its coverage.

Both are given the same tracker settings (:data:`benchmarks.multitarget.PROCESS_NOISE`, the lifecycle
constants, the gate, the detection probability) and the same clutter density.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from benchmarks import multitarget as mt
from gcs.config import Scenario
from gcs.core.world import World

__all__ = ["OurStepper", "PeerStepper", "run_methods"]


class OurStepper:
    """Our tracker (``kind``: ``gaussian`` or ``road``; ``association``: ``gnn`` or ``jpda``) in the engine."""

    def __init__(self, association: str, kind: str, scans, scene: mt.Scene, config: mt.BenchConfig, world: World,
                 base: Scenario, clutter_density: float) -> None:
        from benchmarks.closed_loop import EngineLoop
        from benchmarks.many_targets_loop import ScanScene, many_target_scenario

        vehicles = scene.vehicle_xyz.shape[1]
        scenario = many_target_scenario(base, association, config.pd, config.clutter, vehicles, kind=kind,
                                        clutter_density=clutter_density)
        roster = [v.id for v in scenario.vehicles]
        self.loop = EngineLoop(scenario, world, np.random.default_rng(0), plans=False)
        self.loop.declare(roster, 0.0)
        self.scene = ScanScene(roster, scene, scans, self.loop.engine.tracker.sensors[0], scenario.time.step_s)
        self.scans = len(scans)

    def step(self, k: int) -> None:
        from benchmarks.closed_loop import fly_step

        fly_step(self.loop, self.scene, k)
        if k == self.scans - 1:
            self.loop.finish(self.scans * self.loop.step_s)

    def result(self) -> mt.MethodRun:
        from benchmarks.many_targets_loop import confirmed

        steps = [confirmed(self.loop, k) for k in range(self.scans)]
        return mt.MethodRun(tuple(ids for ids, _ in steps), tuple(xy for _, xy in steps),
                            tuple(self.loop.tick_seconds[k] for k in range(self.scans)))


class PeerStepper:
    """Stone Soup's GNN or JPDA (:mod:`benchmarks.stonesoup_peer`) configured as ours."""

    def __init__(self, name: str, scans, config: mt.BenchConfig, target_height_m: float,
                 clutter_density: float) -> None:
        from benchmarks import stonesoup_peer

        peer = stonesoup_peer.PeerConfig(process_noise=mt.PROCESS_NOISE, pd=config.pd, prob_gate=mt.GATE_PROBABILITY,
                                         clutter_density=clutter_density, target_height_m=target_height_m,
                                         confirm_m=mt.CONFIRM_M, confirm_n=mt.CONFIRM_N,
                                         max_missed_scans=mt.MAX_MISSED_SCANS,
                                         max_position_var_m2=mt.MAX_POSITION_TRACE_M2)
        make = stonesoup_peer.gnn_tracker if name == "stonesoup_gnn" else stonesoup_peer.jpda_tracker
        self.peer, self.scans = make(peer), scans
        self.ids: list[tuple] = []
        self.xy: list[np.ndarray] = []
        self.seconds: list[float] = []

    def step(self, k: int) -> None:
        from benchmarks.stonesoup_peer import confirmed, scan_peer

        self.seconds.append(scan_peer(self.peer, self.scans[k], k))
        tracks = confirmed(self.peer)
        self.ids.append(tuple(t[0] for t in tracks))
        self.xy.append(np.array([[x, y] for _, x, y in tracks], dtype=np.float64).reshape(-1, 2))

    def result(self) -> mt.MethodRun:
        return mt.MethodRun(tuple(self.ids), tuple(self.xy), tuple(self.seconds))


def run_methods(scans, scene: mt.Scene, config: mt.BenchConfig, methods: Sequence[str], world: World,
                base: Scenario, target_height_m: float, clutter_density: float) -> dict[str, mt.MethodRun]:
    """Every method over the same scans (ours on ``base``'s city and UAVs), alternated scan by scan (module
    docstring)."""
    height = float(target_height_m)
    ours = {"gnn": ("gnn", "gaussian"), "jpda": ("jpda", "gaussian"), "gnn_roads": ("gnn", "road"),
            "jpda_roads": ("jpda", "road")}
    steppers = [OurStepper(*ours[name], scans, scene, config, world, base, clutter_density) if name in ours
                else PeerStepper(name, scans, config, height, clutter_density) for name in methods]
    for k in range(len(scans)):
        for i in range(len(steppers)):
            steppers[(i + k) % len(steppers)].step(k)
    return {name: stepper.result() for name, stepper in zip(methods, steppers)}
