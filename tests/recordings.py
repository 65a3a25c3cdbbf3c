"""A recording like ``gcs run --record`` makes, without a network, for the replay viewer's tests."""

from __future__ import annotations

from pathlib import Path

from gcs.adapters.recording import Recorder, read_recording
from sim_vehicles.recording import record_scene
from gcs.config import Scenario
from gcs.core.world import World
from gcs.recordings.replay import process
from protocols.codec import encode
from protocols.keys import track_key

__all__ = ["run_recording"]


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
