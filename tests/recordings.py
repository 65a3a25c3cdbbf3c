"""A recording like ``gcs run --record`` makes, without a network, for the replay viewer's tests."""

from __future__ import annotations

from pathlib import Path

from gcs.adapters.recording import Recorder, read_recording
from sim_vehicles.recording import record_scene
from gcs.config import Scenario
from gcs.core.world import World
from gcs.recordings.replay import process
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key, track_key, truth_key
from protocols.messages import NavReport, TargetTruth
from protocols.sensor_report import SensorReport

__all__ = ["run_recording", "still_recording"]

NS = 1_000_000_000


def run_recording(folder: Path, scenario: Scenario, world: World, duration_s: float, seed: int) -> Path:
    """Simulated inputs (receive time = stamp) and the daemon's tracks (1 ms after their step) in one file."""
    inputs, path = folder / "inputs.mcap", folder / "run.mcap"
    record_scene(scenario, world, inputs, duration_s=duration_s, seed=seed)
    tracks, _, _ = process(inputs, scenario)
    assert tracks, "the simulated run should give tracks"
    rows = [(r.log_time_ns, r.key, r.payload, r.encoding) for r in read_recording(inputs)]
    rows += [(t.stamp_ns + 1_000_000, track_key(t.target_id), *encode(t)) for t in tracks]
    with Recorder(path, scenario=scenario) as recorder:  # as gcs run --record: the run's scenario named
        for log_time, key, payload, encoding in sorted(rows, key=lambda row: row[0]):
            recorder.write(key, payload, encoding, log_time)
    return path


def still_recording(path: Path, scenario: Scenario, steps: int = 20, epoch_ns: int = 1_700_000_000 * NS) -> Path:
    """A scene about the city, not the flight: the UAVs hold their start points (heading east) and the target waits at
    its start, one report, nav report and truth a second for ``steps`` seconds from ``epoch_ns``."""
    with Recorder(path) as recorder:
        for vehicle in scenario.vehicles:
            recorder.write_liveliness(alive_key(vehicle.id), True, epoch_ns - NS // 2)
        for k in range(steps):
            stamp = epoch_ns + k * NS
            for slot, vehicle in enumerate(scenario.vehicles):
                x, y = vehicle.start_enu_m
                report = SensorReport(vehicle_id=vehicle.id, seq=k + 1, stamp_ns=stamp,
                                      vehicle_position_enu_m=(x, y, vehicle.altitude_m), detections=())
                nav = NavReport(vehicle_id=vehicle.id, seq=k + 1, stamp_ns=stamp, heading_rad=0.0,
                                velocity_enu_mps=(vehicle.speed_mps, 0.0, 0.0))
                recorder.write(report_key(vehicle.id), *encode(report), stamp + slot * 10_000_000)
                recorder.write(nav_key(vehicle.id), *encode(nav), stamp + slot * 10_000_000 + 1)
            truth = TargetTruth(target_id=scenario.target.id, seq=k + 1, stamp_ns=stamp,
                                position_enu_m=scenario.target.start_enu_m, velocity_enu_mps=(0.0, 0.0))
            recorder.write(truth_key(scenario.target.id), *encode(truth), stamp + 50_000_000)
    return path
