"""The road tracker through the live daemon and through ``gcs replay --process`` gives the same tracks bit for bit.

Its random draws come from a generator seeded with ``[estimator.road] seed`` and each step's stamp
(:class:`gcs.core.roads.tracking.RoadTracking`), never from the daemon's clock or its planner: a
synthetic recording of simulated vehicles (:func:`sim_vehicles.recording.record_scene`; a car driving
the default city's street grid) is republished over loopback Zenoh to a daemon running in a thread,
and processing the daemon's recording gives its tracks byte for byte. With another seed the tracks
differ, so that the seed really is what the draws come from.
"""

from __future__ import annotations

import msgspec
import pytest

from gcs.recordings.replay import process, truth_error
from gcs.scenarios import load_scenario
from tests.integration.test_engine_replay import S, _inputs, _live, _replayed

pytestmark = pytest.mark.integration

_PAPER = load_scenario("wang2012_urban")
ROADS = msgspec.structs.replace(
    _PAPER, target=msgspec.structs.replace(_PAPER.target, motion="streets"),
    estimator=msgspec.structs.replace(_PAPER.estimator, kind="road"))
"""wang2012_urban's city and UAVs (the world the daemon of test_engine_replay is given), a car on its streets,
and the road tracker."""


def _with_seed(seed: int):
    return msgspec.structs.replace(ROADS, estimator=msgspec.structs.replace(
        ROADS.estimator, road=msgspec.structs.replace(ROADS.estimator.road, seed=seed)))


def test_a_run_with_the_road_tracker_replays_bit_for_bit(tmp_path) -> None:
    recording, live, counters = _live(tmp_path, _inputs(tmp_path, ROADS), ROADS)
    assert counters.get("rejected.late", 0) == 0 and counters.get("rejected.diverged", 0) == 0, counters
    assert _replayed(recording, ROADS) == live
    assert _replayed(recording, _with_seed(1)) != live  # the draws are the seed's
    tracks, _, _ = process(recording, ROADS)
    rmse, scored = truth_error(recording, tracks, S, ROADS.target.id)
    assert scored >= len(live) - 1 and rmse < 20.0  # three UAVs on the car: a few metres, not a lost track
    assert all(len(t.prediction) == ROADS.planner.sight.horizon_steps for t in tracks)
