"""The daemon tracking every car of ``multitarget_urban`` against the simulated vehicles, and its replay.

The daemon runs in a thread against the simulated vehicles (a thread too) on loopback,
recording what it receives and publishes. Five cars drive the streets, two of them side
by side; the sensors miss one scan in ten and raise a false alarm a scan. Judged against
the simulator's truth in the recording: most cars have a track of their own and few
tracks are spare, each current track answers on ``gcs/track/t<id>`` (a deleted one does
not), ``gcs status`` lists them, the UAVs are planned for, and ``gcs replay --process``
gives back every track bit for bit.
"""

from __future__ import annotations

import re
from collections import defaultdict

import numpy as np
from scipy.optimize import linear_sum_assignment

from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings, open_session, query
from gcs.config.world import build_world
from gcs.daemon.status_cli import query_status
from gcs.recordings.replay import process
from gcs.scenarios import load_scenario
from protocols.codec import decode, encode
from protocols.keys import track_key
from protocols.messages import TargetTruth, TrackEstimate
from tests.integration.daemon_flight import daemon_through_a_flight
from tests.integration.sim_harness import wait_until

SCENARIO = load_scenario("multitarget_urban")
WORLD = build_world(SCENARIO)
RATE = 5.0
DURATION_S = 60.0
EPOCH_NS = 1_000_000_000_000
ON_CAR_M = 50.0
"""A track within this of a car's truth is on it (the sensor's 10 m range noise at 300-1500 m, 0.05 rad azimuth)."""


def _by_stamp(recording, kind: type, key_part: str) -> dict[int, dict[str, tuple[float, float]]]:
    """Recorded positions by stamp and id: the tracks (``/track/``) or the simulator's truths (``/sim/truth/``)."""
    out: dict[int, dict[str, tuple[float, float]]] = defaultdict(dict)
    for recorded in read_recording(recording):
        if key_part in recorded.key:
            message = decode(recorded.payload, recorded.encoding, kind)
            name = message.target_id
            xy = message.state[:2] if isinstance(message, TrackEstimate) else message.position_enu_m[:2]
            out[message.stamp_ns][name] = (float(xy[0]), float(xy[1]))
    return out


def _answers(daemon, session, endpoint: str):
    """The daemon's current tracks, the tracks a query of every track key answers (id: key) and the status
    ``gcs status`` reads; None when a step was fused in between (the last steps go on their timeouts)."""
    current = daemon.engine.tracks_now  # replaced whole each step, never changed in place
    answered = {decode(s.payload.to_bytes(), str(s.encoding), TrackEstimate).target_id: str(s.key_expr)
                for s in query(session, track_key("any").replace("any", "*"), 5.0)}
    status = query_status(ZenohSettings(connect=(endpoint,)), "gcs", 5.0)
    return (current, answered, status) if daemon.engine.tracks_now is current else None


def test_the_daemon_tracks_every_car_publishes_each_track_and_replay_reproduces_them(tmp_path) -> None:
    recording = tmp_path / "run.mcap"
    with daemon_through_a_flight(SCENARIO, WORLD, recording, seed=5, duration_s=DURATION_S, rate=RATE,
                                 epoch_ns=EPOCH_NS) as (daemon, endpoint):
        with open_session(ZenohSettings(connect=(endpoint,))) as session:
            seen: list = []
            wait_until(lambda: seen.append(_answers(daemon, session, endpoint)) or seen[-1] is not None, 60,
                       "a query and a status between two fused steps")
        current, answered, status = seen[-1]
    counters = status.counters
    assert counters.get("errors.decision", 0) == 0 and counters.get("errors.planning", 0) == 0, counters
    assert counters.get("decisions", 0) >= 10, counters  # the vehicles were planned for, many times

    tracks = _by_stamp(recording, TrackEstimate, "/track/")
    truths = _by_stamp(recording, TargetTruth, "/sim/truth/")
    assert all(re.fullmatch(r"t[0-9]+", name) for step in tracks.values() for name in step)
    # Late in the run, most cars have a track of their own (one to one, closest pairs first), and few tracks
    # are spare (a duplicate, or on clutter).
    cars_tracked, spare = [], []
    for stamp in sorted(tracks)[-10:]:
        names, truth = list(tracks[stamp]), truths[stamp]
        cars = sorted(truth)
        distance = np.array([[np.hypot(tracks[stamp][n][0] - truth[c][0], tracks[stamp][n][1] - truth[c][1])
                              for c in cars] for n in names])
        rows, cols = linear_sum_assignment(np.minimum(distance, ON_CAR_M + 1.0))
        paired = int((distance[rows, cols] <= ON_CAR_M).sum())
        cars_tracked.append(paired)
        spare.append(len(names) - paired)
    assert np.median(cars_tracked) >= 3 and np.median(spare) <= 1, (cars_tracked, spare)  # most of the 5 cars

    # Each current track answers on its own key; a deleted one does not.
    assert set(answered) == set(current) and all(key == track_key(name) for name, key in answered.items())
    assert [(t.target_id, t.stamp_ns, t.x_m) for t in status.tracks] == [
        (t.target_id, t.stamp_ns, round(t.state[0], 2)) for t in current.values()]  # gcs status lists them
    assert {name for step in tracks.values() for name in step} - set(current), "no track was deleted in the run"

    # The recording gives back every track bit for bit.
    live = [r.payload for r in read_recording(recording) if "/track/" in r.key]
    replayed, _, replay_counters = process(recording, SCENARIO)
    assert len(live) >= 3 * (DURATION_S - 30) and [encode(t)[0] for t in replayed] == live
