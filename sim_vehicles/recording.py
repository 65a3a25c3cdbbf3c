"""The simulated vehicles' messages recorded without a network, as ``gcs record`` (or ``gcs run --record``) records
them: a recording to replay (``gcs replay``) or to process (``gcs replay --process``) made in one process.

The scenario's vehicles (:class:`sim_vehicles.scene.Scene`, loitering, no ground station) declare
their liveliness tokens, then send their reports, nav reports and the targets' truths at the
scenario's rates for ``duration_s`` simulated seconds; each is written with the recorder
(:class:`gcs.adapters.recording.Recorder`) received at its stamp.
"""

from __future__ import annotations

from pathlib import Path

from gcs.adapters.recording import Recorder
from gcs.config import Scenario
from gcs.core.world import World
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key, truth_key
from sim_vehicles.scene import Scene

__all__ = ["record_scene"]

NS_PER_S = 1_000_000_000


def record_scene(scenario: Scenario, world: World, path: Path, duration_s: float, seed: int) -> dict:
    """Simulate ``duration_s`` of the scenario's inputs into an MCAP file (module docstring), the scene starting
    at stamp 1 s; the message counts by kind (``report``, ``nav``, ``truth``)."""
    scene = Scene(scenario, world, seed=seed, epoch_ns=NS_PER_S)
    sim = scenario.simulation
    dt = sim.physics_step_s
    report_every, nav_every = round(1.0 / sim.report_rate_hz / dt), round(1.0 / sim.nav_rate_hz / dt)
    counts = {"report": 0, "nav": 0, "truth": 0}
    with Recorder(path, scenario=scenario) as recorder:
        for vehicle_id in scene.vehicles:  # each simulated vehicle declares its token before it sends anything
            recorder.write_liveliness(alive_key(vehicle_id), True, scene.stamp_ns - 1)
        for step in range(round(duration_s / dt)):
            if step % nav_every == 0:
                for vehicle_id in scene.vehicles:
                    payload, encoding = encode(scene.nav_report(vehicle_id))
                    recorder.write(nav_key(vehicle_id), payload, encoding, scene.stamp_ns)
                    counts["nav"] += 1
            if step % report_every == 0:
                for vehicle_id in scene.vehicles:
                    payload, encoding = encode(scene.sensor_report(vehicle_id))
                    recorder.write(report_key(vehicle_id), payload, encoding, scene.stamp_ns)
                    counts["report"] += 1
                for truth in scene.truths():
                    payload, encoding = encode(truth)
                    recorder.write(truth_key(truth.target_id), payload, encoding, scene.stamp_ns)
                    counts["truth"] += 1
            scene.advance(dt, {})
    return counts
