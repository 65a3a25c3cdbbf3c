"""``gcs replay``'s work: a recording (``gcs record``, :mod:`gcs.recordings.record`; ``gcs run --record``) summarised,
processed, or fed back (the command line is :mod:`gcs.recordings.replay_cli`).

* ``gcs replay FILE --info`` summarises channels, counts, duration, vehicles and scenario.
* ``gcs replay FILE [--rate R | --fast]`` republishes the recorded inputs
  (reports, nav, truth, the vehicles' scenario announcements; liveliness as tokens) so that a
  running daemon consumes them, keeping their recorded spacing divided by ``R``, or as fast as
  possible.
* ``gcs replay FILE --view [--rate R] [--http ADDRESS]`` shows it on the live map
  with play/pause and speed (:mod:`gcs.recordings.replay_view`); ``--foxglove-mcap OUT``
  converts it to an MCAP file of Foxglove's map schemas.
* ``gcs replay FILE --process [--plan] [--out TRACKS.mcap|.csv]`` runs the
  estimator (and the planner) on the file directly, without Zenoh: the daemon's own engine
  (:mod:`gcs.engine`: validation, step assembly, navigation, fusion), fed the recorded
  inputs, liveliness and heartbeats with their receive times, under the options of the
  run (``--navigation``, ``--accept-unlisted``, ``--max-wait``, the scenario's roster),
  so a recording of a live run gives back the daemon's tracks bit for bit,
  provided no report or nav report was late in the live run (the daemon's
  ``rejected.late`` and ``rejected.late_nav`` counters are zero). With the run's
  ``--federation``, ``--member`` and ``--area``, the federation's messages and members'
  liveliness recorded beside them are fed to the engine too.
"""

from __future__ import annotations

import csv
import logging
import math
import threading
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import zenoh

from gcs.adapters.recording import HEARTBEAT_ENCODING, LIVELINESS_ENCODING, Recorded, Recorder, read_recording
from gcs.adapters.zenoh_session import has_subscribers, open_session
from gcs.config import Scenario, estimator_kind
from gcs.config.world import build_world
from gcs.core.metrics import gospa
from gcs.core.world import World
from gcs.engine.records import GOSPA_CUTOFF_M
from gcs.engine.steps import HOLD_WAITS
from gcs.engine.engine import Engine, EngineOptions
from gcs.engine.events import (Arrived, Heartbeat, PlannerFree, PublishMemberTracks, PublishPlan, PublishTrack,
                               SubmitPlan, Tick)
from gcs.engine.federation import FederationOptions
from gcs.engine.plan_at_once import plan_at_once
from gcs.recordings.keys import INPUT_KINDS, VEHICLE_KINDS, key_kind, prefix_of
from gcs.recordings.recorded_scenario import ScenarioFinder
from protocols.codec import decode, encode
from protocols.errors import ProtocolError
from protocols.keys import DEFAULT_PREFIX, plan_key, track_key
from protocols.messages import MemberTracks, PlanCommand, TargetTruth, TrackEstimate

__all__ = ["process", "needs_world", "summarise", "write_outputs", "truth_error", "republish", "INPUT_KINDS", "key_kind"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
TOKEN_SETTLE_S = 0.5
"""Wait after declaring the recorded vehicles' liveliness tokens, before republishing data."""


# ------------------------------------------------------------------- --info

def summarise(path: Path) -> dict:
    """Channels (key, encoding, count), message count, duration, vehicles and scenario (the metadata's, else the
    first a vehicle announced: ``{"name", "fingerprint"}``, or None) of a recording."""
    channels: Counter = Counter()
    vehicles: set[str] = set()
    first = last = None
    stamps: list[int] = []
    scenario = ScenarioFinder()
    for record in read_recording(path, on_metadata=scenario.metadata):
        channels[(record.key, record.encoding)] += 1
        first = record.log_time_ns if first is None else min(first, record.log_time_ns)
        last = record.log_time_ns if last is None else max(last, record.log_time_ns)
        kind, ident = key_kind(record.key)
        if kind in VEHICLE_KINDS and ident is not None:
            vehicles.add(ident)
        if kind == "report":
            stamps.append(record.publish_time_ns)
        scenario.see(record, kind)
    return {
        "file": str(path), "messages": sum(channels.values()),
        "duration_s": 0.0 if first is None or last is None else (last - first) / NS_PER_S,
        "stamp_span_s": (max(stamps) - min(stamps)) / NS_PER_S if stamps else 0.0,
        "reports": len(stamps), "vehicles": sorted(vehicles),
        "scenario": None if scenario.found is None else dict(zip(("name", "fingerprint"), scenario.found)),
        "channels": [{"key": k, "encoding": e, "messages": n} for (k, e), n in sorted(channels.items())],
    }


# ---------------------------------------------------------------- --process

def process(path: Path, scenario: Scenario, prefix: str = DEFAULT_PREFIX, world: World | None = None,
            seed: int = 0, navigation: str = "auto", accept_unlisted: bool = False, max_wait_s: float = 0.5,
            planner: str | None = None, plan: bool = True,
            federation: FederationOptions | None = None, member_tracks: list[MemberTracks] | None = None
            ) -> tuple[list[TrackEstimate], list[PlanCommand], Counter]:
    """The daemon's engine (:class:`~gcs.engine.engine.Engine`) on a recording: its tracks, plans and counters.

    The recorded inputs go to the same engine as live, in recorded order, each with its recorded
    receive time as the clock (the steps whose wait ran out before an input came in are released
    before it is handled, as the live loop, idle between inputs, did): samples, liveliness tokens
    and the MAVLink heartbeats the daemon heard (:data:`~gcs.adapters.recording.HEARTBEAT_ENCODING`),
    so a step is released for the same vehicles
    alive as live (token or heartbeat) or when its wait expires. The options that change acceptance
    are the daemon's (``gcs run``'s flags of the same names): ``navigation`` (``--navigation``),
    ``accept_unlisted`` (``--accept-unlisted``), ``max_wait_s`` (``--max-wait``), and the roster is
    the ``scenario``'s. With a ``world`` every fused step is handed to the planner, for the vehicles
    alive then, as the daemon hands over the newest when its planner is free; here the planner
    plans at once, with ``seed``, to the end of every generation (no deadline), so the plans are
    reproducible; the daemon's own plans stop at its deadline.

    ``federation`` (``--federation``, ``--member``, ``--area``) makes the engine the member it was live: the
    recorded members' tracks and liveliness under the federation's prefix are fed to it as they came (without
    it they are left out); the member's own ``MemberTracks`` it publishes go to ``member_tracks`` if given.

    ``plan`` False fuses without planning, even with a world. A ``[multitarget]`` scenario needs its
    world to fuse (which tracks a sensor covered, past the buildings), and so does the road tracker
    (the road graph, and the sight table of its negative information): without one given, it is
    built from the scenario (a generated city; a GeoJSON city needs it passed in).

    Returns the tracks, the plans (empty without a world) and the counters.
    """
    plans_too = world is not None and plan
    if world is None and needs_world(scenario):
        world = build_world(scenario)
    engine = Engine(scenario, world, EngineOptions(prefix=prefix, accept_unlisted=accept_unlisted,
                                                   navigation=navigation, max_wait_s=max_wait_s, planner=planner,
                                                   plan_every_step=True, federation=federation))
    rng = np.random.default_rng(seed)
    tracks: list[TrackEstimate] = []
    plans: list[PlanCommand] = []

    def carry_out(actions) -> None:
        for action in actions:
            if isinstance(action, PublishTrack):
                tracks.append(action.track)
            elif isinstance(action, PublishPlan):
                plans.append(action.command)
            elif isinstance(action, PublishMemberTracks) and member_tracks is not None:
                member_tracks.append(action.message)
            elif isinstance(action, SubmitPlan):
                carry_out(plan_at_once(engine, action.job, rng))

    def release(now: float) -> None:
        """Fuse the steps ready at ``now`` one at a time, each planned (with a world) before the next."""
        tick = Tick(now, max_steps=1)
        while True:
            carry_out(engine.feed(tick))
            if plans_too:
                carry_out(engine.feed(PlannerFree(now)))
            if not engine.released:
                return
            tick = Tick(now, timeouts=False, max_steps=1)

    federated = ("member", "member_alive") if federation is not None else ()
    now = 0.0
    for record in read_recording(path):
        kind, ident = key_kind(record.key)
        if kind in federated and federation is not None and prefix_of(record.key) != federation.prefix:
            continue  # another federation's
        now = record.log_time_ns / NS_PER_S
        if kind in ("alive", "report", "nav", "truth", *federated):
            release(now)  # what timed out before it came in: the live loop, idle, released it before
        if kind == "alive" and record.encoding == HEARTBEAT_ENCODING and ident is not None:
            engine.feed(Heartbeat(ident, now))
        elif kind in ("alive", *federated) and record.encoding == LIVELINESS_ENCODING:  # as the daemon saw it
            engine.feed(Arrived("alive" if record.payload == b"alive" else "gone", record.key, b"", "",
                                record.log_time_ns, now))
        elif kind in ("report", "nav", "truth", *federated):
            engine.feed(Arrived("sample", record.key, record.payload, record.encoding, record.log_time_ns, now))
        else:
            continue  # the daemon's own outputs
        release(now)
    release(now + HOLD_WAITS * max_wait_s + 1.0)  # past every open step's deadline
    return tracks, plans, engine.counters_now()


def needs_world(scenario: Scenario) -> bool:
    """Whether fusing the scenario's reports needs its world: many targets (the coverage past the buildings), or the
    road tracker (:func:`gcs.config.estimator_kind`)."""
    return scenario.multitarget is not None or estimator_kind(scenario) == "road"


def _recorded_truths(path: Path) -> dict[int, dict[str, tuple[float, float]]]:
    """The simulator's truths recorded beside the inputs: position by stamp and target id."""
    truths: dict[int, dict[str, tuple[float, float]]] = {}
    for record in read_recording(path):
        if key_kind(record.key)[0] == "truth":
            try:
                message = decode(record.payload, record.encoding, TargetTruth)
            except ProtocolError:
                continue  # counted by --process's ingest
            truths.setdefault(message.stamp_ns, {})[message.target_id] = message.position_enu_m[:2]
    return truths


def _nearest_stamp(stamps: np.ndarray, stamp_ns: int, step_ns: int) -> int | None:
    """The recorded stamp nearest ``stamp_ns``, within a tenth of a step (as the daemon scores its steps)."""
    nearest = int(stamps[np.argmin(np.abs(stamps - stamp_ns))])
    return nearest if abs(nearest - stamp_ns) <= step_ns // 10 else None


def truth_error(path: Path, tracks: list[TrackEstimate], step_ns: int, target_id: str) -> tuple[float | None, int]:
    """RMSE (m) of the tracks' positions against the truth of ``target_id`` recorded beside them, and how many
    tracks were scored (each against the truth nearest its stamp); (None, 0) for a recording without it."""
    truth = {stamp: by_id[target_id] for stamp, by_id in _recorded_truths(path).items() if target_id in by_id}
    if not truth:
        return None, 0
    stamps = np.array(sorted(truth))
    squared = []
    for track in tracks:
        nearest = _nearest_stamp(stamps, track.stamp_ns, step_ns)
        if nearest is not None:
            x, y = truth[nearest]
            squared.append((track.state[0] - x) ** 2 + (track.state[1] - y) ** 2)
    return (math.sqrt(sum(squared) / len(squared)) if squared else None), len(squared)


def truth_gospa(path: Path, tracks: list[TrackEstimate], step_ns: int) -> tuple[float | None, int]:
    """Mean GOSPA (m; c = :data:`~gcs.engine.records.GOSPA_CUTOFF_M`, p = 2, alpha = 2) against every target's truth
    recorded beside the tracks, over every stamp the simulator published truths at (the tracks within a tenth
    of a step of it; none: every target missed), and how many stamps were scored; (None, 0) without truth."""
    truths = _recorded_truths(path)
    if not truths:
        return None, 0
    by_step: dict[int, list[tuple[float, float]]] = {}
    for track in tracks:
        by_step.setdefault(track.stamp_ns, []).append((track.state[0], track.state[1]))
    track_stamps = np.array(sorted(by_step), dtype=np.int64)
    distances = []
    for stamp, truth in sorted(truths.items()):
        nearest = _nearest_stamp(track_stamps, stamp, step_ns) if len(track_stamps) else None
        positions = np.array(by_step[nearest] if nearest is not None else [], dtype=np.float64).reshape(-1, 2)
        distances.append(gospa(positions, np.array([truth[n] for n in sorted(truth)]), GOSPA_CUTOFF_M).distance)
    return float(np.mean(distances)), len(distances)


def write_outputs(tracks: list[TrackEstimate], plans: list[PlanCommand], out: Path,
                  prefix: str = DEFAULT_PREFIX) -> None:
    """Tracks (and plans) to MCAP, one channel per key like a recording, or tracks to CSV (by the suffix)."""
    if out.suffix == ".csv":
        with open(out, "w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["target_id", "seq", "stamp_ns", "x_m", "y_m", "vx_mps", "vy_mps", "var_x_m2",
                             "var_y_m2", "contributing_vehicles"])
            for t in tracks:
                n = len(t.state)
                writer.writerow([t.target_id, t.seq, t.stamp_ns, *[repr(v) for v in t.state[:4]],
                                 repr(t.covariance[0]), repr(t.covariance[n + 1]), " ".join(t.contributing_vehicles)])
        return
    with Recorder(out) as recorder:
        messages: list[TrackEstimate | PlanCommand] = [*tracks, *plans]
        for message in sorted(messages, key=lambda m: m.stamp_ns):
            key = (track_key(message.target_id, prefix) if isinstance(message, TrackEstimate)
                   else plan_key(message.vehicle_id, prefix))
            payload, encoding = encode(message)
            recorder.write(key, payload, encoding, message.stamp_ns)


# -------------------------------------------------------------- republish

def _inputs(path: Path) -> Iterator[tuple[Recorded, str, str | None]]:
    """The recorded inputs that travel on Zenoh (MAVLink heartbeats the daemon heard do not)."""
    for record in read_recording(path):
        kind, ident = key_kind(record.key)
        if kind in INPUT_KINDS and record.encoding != HEARTBEAT_ENCODING:
            yield record, kind, ident


def _under(prefix: str, key: str) -> str:
    """A recorded key under ``prefix`` instead of the prefix it was recorded under."""
    own = prefix_of(key)
    return key if own is None else prefix + key[len(own):]


def republish(path: Path, settings, prefix: str, rate: float | None, stop: threading.Event,
              wait_for_subscriber_s: float = 5.0) -> Counter:
    """Put the recorded inputs back on Zenoh under ``prefix``; ``rate`` None is as fast as possible.

    Publishers for every recorded input key, and the liveliness tokens of every
    vehicle alive in the recording, are declared first, and up to
    ``wait_for_subscriber_s`` is given for a subscriber (the daemon) to match
    them, so that the first messages are not published before anyone listens.
    """
    counts: Counter = Counter()
    inputs = [(record.key, kind, record.payload) for record, kind, _ in _inputs(path)]
    keys = sorted({key for key, kind, _ in inputs if kind != "alive"})
    alive = sorted({key for key, kind, payload in inputs if kind == "alive" and payload == b"alive"})
    with open_session(settings) as session:
        publishers = {key: session.declare_publisher(_under(prefix, key),
                                                     congestion_control=zenoh.CongestionControl.BLOCK)
                      for key in keys}
        # every vehicle that was alive in the recording is declared first, so that a daemon expects its
        # reports from the first step even when they are replayed as fast as possible
        tokens = {_under(prefix, key): session.liveliness().declare_token(_under(prefix, key)) for key in alive}
        deadline = time.monotonic() + wait_for_subscriber_s
        while not all(has_subscribers(p) for p in publishers.values()) and time.monotonic() < deadline:
            if stop.wait(0.02):
                break
        if tokens:
            stop.wait(TOKEN_SETTLE_S)  # liveliness travels apart from the data: let the tokens arrive first
        start_wall, start_log = time.monotonic(), None
        try:
            for record, kind, _ in _inputs(path):
                if stop.is_set():
                    break
                start_log = record.log_time_ns if start_log is None else start_log
                if rate is not None:
                    due = start_wall + (record.log_time_ns - start_log) / NS_PER_S / rate
                    if stop.wait(max(0.0, due - time.monotonic())):
                        break
                if kind == "alive":
                    key = _under(prefix, record.key)
                    if record.payload == b"alive" and key not in tokens:
                        tokens[key] = session.liveliness().declare_token(key)
                    elif record.payload == b"gone" and key in tokens:
                        tokens.pop(key).undeclare()
                    counts["liveliness"] += 1
                    continue
                publishers[record.key].put(record.payload, encoding=zenoh.Encoding(record.encoding))
                counts[kind] += 1
        finally:
            for token in tokens.values():
                token.undeclare()
            for publisher in publishers.values():
                publisher.undeclare()
    return counts
