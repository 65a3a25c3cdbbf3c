"""``gcs record`` and ``gcs replay``: MCAP recordings of the Zenoh traffic, and feeding them back.

* ``gcs record -o FILE.mcap`` subscribes to everything under the prefix and
  writes it (:mod:`gcs.adapters.recording`); SIGINT/SIGTERM finish the file.
* ``gcs replay FILE --info`` summarises channels, counts, duration and vehicles.
* ``gcs replay FILE [--rate R | --fast]`` republishes the recorded inputs
  (reports, nav, truth; liveliness as tokens) so that a running daemon consumes
  them, keeping their recorded spacing divided by ``R``, or as fast as possible.
* ``gcs replay FILE --view [--rate R] [--http ADDRESS]`` shows it on the live map
  with play/pause and speed (:mod:`gcs.replay_view`); ``--foxglove-mcap OUT``
  converts it to an MCAP file of Foxglove's map schemas.
* ``gcs replay FILE --process [--plan] [--out TRACKS.mcap|.csv]`` runs the
  estimator (and the planner) on the file directly, without Zenoh: the same validation, step assembly and
  fusion as the daemon (:mod:`gcs.daemon.fusion`), with the same vehicle
  navigation (``--navigation``, default ``auto``: :mod:`gcs.daemon.navigation`),
  so a recording of a live run gives back the daemon's tracks bit for bit,
  provided no report or nav report was late in the live run (the daemon's
  ``rejected.late`` and ``rejected.late_nav`` counters are zero).
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import logging
import math
import queue
import signal
import threading
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import zenoh

from gcs.adapters.foxglove_out import FoxgloveMissing, add_foxglove_arguments
from gcs.adapters.recording import LIVELINESS_ENCODING, Recorded, Recorder, RecordingError, read_recording
from gcs.adapters.web import add_http_argument
from gcs.adapters.zenoh_io import Received
from gcs.adapters.zenoh_session import DEFAULT_ENDPOINT, add_zenoh_arguments, open_session, required_settings
from gcs.config import Scenario, ScenarioError
from gcs.daemon.cli import add_navigation_argument
from gcs.core.tracker import plan, prediction
from gcs.core.world import World
from gcs.daemon.fusion import FusionDiverged, PlanMemory, fuse_step, plan_commands, track_message
from gcs.daemon.ingest import Ingest
from gcs.daemon.navigation import navigator_for
from gcs.daemon.registry import Registry
from gcs.daemon.steps import StepAssembler
from gcs.scenarios import DEFAULT_SCENARIO, load_scenario, scenario_base_dir
from gcs.tracking import scenario_planner, subset_config, tracker_config
from gcs.world_loader import build_world
from protocols.codec import decode, encode
from protocols.errors import ProtocolError
from protocols.keys import DEFAULT_PREFIX, parse_key, plan_key, track_key, validate_prefix
from protocols.messages import NavReport, PlanCommand, SensorReport, TargetTruth, TrackEstimate

__all__ = ["add_record", "add_replay", "process", "summarise", "write_outputs", "truth_error", "INPUT_KINDS"]

log = logging.getLogger(__name__)

INPUT_KINDS = ("report", "nav", "truth", "alive")
"""Key kinds that are inputs of the daemon (the rest, tracks, plans and status, are its outputs)."""
NS_PER_S = 1_000_000_000
TOKEN_SETTLE_S = 0.5
"""Wait after declaring the recorded vehicles' liveliness tokens, before republishing data."""


def _prefix_of(key: str) -> str | None:
    """The prefix a key of the key space is under (``gcs`` for ``gcs/vehicle/uav1/report``)."""
    for marker in ("/vehicle/", "/track/", "/plan/", "/daemon/", "/sim/"):
        if marker in key:
            return key[: key.index(marker)]
    return None


@functools.lru_cache(maxsize=4096)
def _kind(key: str) -> tuple[str | None, str | None]:
    """Kind and id of a key of the key space under any prefix; (None, None) for other keys."""
    prefix = _prefix_of(key)
    if prefix is None:
        return None, None
    try:
        parsed = parse_key(key, prefix)
    except ProtocolError:
        return None, None
    return parsed.kind, parsed.ident


# ------------------------------------------------------------------- --info

def summarise(path: Path) -> dict:
    """Channels (key, encoding, count), message count, duration and vehicles of a recording."""
    channels: Counter = Counter()
    vehicles: set[str] = set()
    first = last = None
    stamps: list[int] = []
    for record in read_recording(path):
        channels[(record.key, record.encoding)] += 1
        first = record.log_time_ns if first is None else min(first, record.log_time_ns)
        last = record.log_time_ns if last is None else max(last, record.log_time_ns)
        kind, ident = _kind(record.key)
        if kind in ("report", "nav", "alive") and ident is not None:
            vehicles.add(ident)
        if kind == "report":
            stamps.append(record.publish_time_ns)
    return {
        "file": str(path), "messages": sum(channels.values()),
        "duration_s": 0.0 if first is None else (last - first) / NS_PER_S,
        "stamp_span_s": (max(stamps) - min(stamps)) / NS_PER_S if stamps else 0.0,
        "vehicles": sorted(vehicles),
        "channels": [{"key": k, "encoding": e, "messages": n} for (k, e), n in sorted(channels.items())],
    }


# ---------------------------------------------------------------- --process

def process(path: Path, scenario: Scenario, prefix: str = DEFAULT_PREFIX, world: World | None = None,
            seed: int = 0, navigation: str = "auto") -> tuple[list[TrackEstimate], list[PlanCommand], Counter]:
    """The daemon's estimation (and planning, with a ``world``) on a recording.

    Messages go through the same :class:`Ingest` and :class:`StepAssembler` as in
    the daemon, in recorded order, with the recorded receive times as the clock;
    a step is released once every vehicle that is alive (its recorded liveliness
    token) or has reported so far has reported for it, or when its wait expires,
    as live. With a ``world`` every step is also planned for the vehicles alive
    then, as the daemon plans, but to the end of every generation (no deadline),
    so the plans are reproducible; the daemon's own plans stop at its deadline.
    ``navigation`` is the daemon's ``--navigation``: with ``skf`` (or ``auto`` on a scenario with GPS-denied
    zones) the nav reports feed the
    same :class:`FleetNavigator`, advanced to each step's stamp before it is fused, and
    the steps wait for them as live.

    Returns the tracks, the plans (empty without a world) and the counters.
    """
    planning = world is not None
    config = tracker_config(scenario, world, scenario_planner(scenario))
    roster = [v.id for v in scenario.vehicles]
    ingest = Ingest(set(roster), prefix)
    steps = StepAssembler(round(scenario.time.step_s * NS_PER_S))
    navigator = navigator_for(navigation, scenario)
    registry = Registry(list(scenario.vehicles), heartbeat_age=lambda vehicle, now: None)
    rng = np.random.default_rng(seed)
    reporters: set[str] = set()
    tracks: list[TrackEstimate] = []
    plans: list[PlanCommand] = []
    memory = PlanMemory()
    estimate = None
    diverged: Counter = Counter()

    def release(ready_steps, now: float) -> None:
        nonlocal estimate
        for ready in ready_steps:
            if navigator is not None:
                navigator.advance_to(ready.stamp_ns)
            try:
                estimate, detections = fuse_step(config, estimate, ready, roster, navigator)
            except FusionDiverged:  # as the daemon: counted, the previous estimate stands
                diverged["rejected.diverged"] += 1
                continue
            if estimate is None:
                continue
            contributing = sorted({roster[d.vehicle] for d in detections})
            predicted = prediction(config, estimate)
            tracks.append(track_message(config, estimate, scenario.target.id, scenario.estimator.model,
                                        len(tracks) + 1, contributing, predicted))
            active = registry.plannable(now)
            if planning and active:
                vehicles = registry.vehicle_state(active, ready.stamp_ns)
                subset = subset_config(config, tuple(roster.index(v) for v in active))
                state, turn_rates, _ = plan(subset, memory.state_for(active, estimate), vehicles, rng,
                                            predicted=predicted)
                memory.remember(active, state, turn_rates)
                plans.extend(plan_commands(vehicles, [registry.entries[v].config for v in active], state.plan,
                                           subset.max_turn_rate, scenario.time.step_s, ready.stamp_ns,
                                           len(plans) + 1, scenario_planner(scenario)))

    now = 0.0
    for record in read_recording(path):
        kind, ident = _kind(record.key)
        now = record.log_time_ns / NS_PER_S
        if kind == "alive" and record.encoding == LIVELINESS_ENCODING:  # as the daemon's registry saw it
            registry.on_liveliness(ident, record.payload == b"alive", now)
            continue
        if kind not in ("report", "nav", "truth"):
            continue  # the daemon's own outputs
        message = ingest.accept(Received("sample", record.key, record.payload, record.encoding, record.log_time_ns))
        if isinstance(message, NavReport):
            registry.on_nav(message)
            if navigator is None:
                continue
            navigator.add(message)
            steps.add_nav(message.vehicle_id, message.stamp_ns)
        elif isinstance(message, SensorReport):
            registry.on_report(message)
            reporters.add(message.vehicle_id)
            steps.add(message, now)
        else:
            continue
        alive = {v for v, entry in registry.entries.items() if entry.token}
        release(steps.ready((alive | reporters) - ingest.off_clock, now), now)
    release(steps.ready(reporters, math.inf), now)
    counters = Counter(ingest.counters) + steps.counters + diverged
    return tracks, plans, counters + (navigator.counters if navigator is not None else Counter())


def truth_error(path: Path, tracks: list[TrackEstimate], step_ns: int) -> tuple[float | None, int]:
    """RMSE (m) of the tracks' positions against the simulator's truth recorded beside them, and how many
    tracks were scored (a track is scored against the truth nearest its stamp, within a tenth of a step,
    as the daemon scores its steps); (None, 0) for a recording without truth."""
    truth: dict[int, tuple[float, float]] = {}
    for record in read_recording(path):
        if _kind(record.key)[0] == "truth":
            try:
                message = decode(record.payload, record.encoding, TargetTruth)
            except ProtocolError:
                continue  # counted by --process's ingest
            truth[message.stamp_ns] = message.position_enu_m
    if not truth:
        return None, 0
    stamps = np.array(sorted(truth))
    squared = []
    for track in tracks:
        nearest = int(stamps[np.argmin(np.abs(stamps - track.stamp_ns))])
        if abs(nearest - track.stamp_ns) <= step_ns // 10:
            x, y = truth[nearest]
            squared.append((track.state[0] - x) ** 2 + (track.state[1] - y) ** 2)
    return (math.sqrt(sum(squared) / len(squared)) if squared else None), len(squared)


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
        for message in sorted([*tracks, *plans], key=lambda m: m.stamp_ns):
            key = (track_key(message.target_id, prefix) if isinstance(message, TrackEstimate)
                   else plan_key(message.vehicle_id, prefix))
            payload, encoding = encode(message)
            recorder.write(key, payload, encoding, message.stamp_ns)


# -------------------------------------------------------------- republish

def _inputs(path: Path) -> Iterator[tuple[Recorded, str, str]]:
    for record in read_recording(path):
        kind, ident = _kind(record.key)
        if kind in INPUT_KINDS:
            yield record, kind, ident


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
        publishers = {key: session.declare_publisher(prefix + key[len(_prefix_of(key)):],
                                                     congestion_control=zenoh.CongestionControl.BLOCK)
                      for key in keys}
        # every vehicle that was alive in the recording is declared first, so that a daemon expects its
        # reports from the first step even when they are replayed as fast as possible
        tokens = {prefix + key[len(_prefix_of(key)):]: session.liveliness().declare_token(
            prefix + key[len(_prefix_of(key)):]) for key in alive}
        deadline = time.monotonic() + wait_for_subscriber_s
        while not all(p.matching_status.matching for p in publishers.values()) and time.monotonic() < deadline:
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
                    key = prefix + record.key[len(_prefix_of(record.key)):]
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


# ---------------------------------------------------------------------- CLI

def _stop_on_signals(event: threading.Event) -> None:
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: event.set())


def add_record(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs record``."""
    parser = sub.add_parser("record", help="record the Zenoh traffic under a prefix to MCAP",
                            description="Subscribe to everything under the prefix (reports, nav, tracks, plans, "
                                        "truth, liveliness) and write the exact payloads to an MCAP file; Ctrl-C "
                                        "or SIGTERM finishes the file.")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.mcap")
    parser.add_argument("--duration", type=float, default=None, metavar="S", help="stop after S wall seconds")
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    parser.set_defaults(handler=_cmd_record)


def _cmd_record(args: argparse.Namespace) -> int:
    try:
        settings = required_settings(args, "gcs record")
    except ValueError as error:
        log.error("%s", error)
        return 2
    validate_prefix(args.prefix)
    stop = threading.Event()
    _stop_on_signals(stop)
    inbox: queue.Queue = queue.Queue()
    deadline = None if args.duration is None else time.monotonic() + args.duration
    try:
        recorder = Recorder(args.output)
    except OSError as error:
        log.error("cannot write %s: %s", args.output, error)
        return 2
    try:
        with open_session(settings) as session:
            session.declare_subscriber(f"{args.prefix}/**", lambda s: inbox.put(
                (str(s.key_expr), s.payload.to_bytes(), str(s.encoding), time.time_ns())))
            session.liveliness().declare_subscriber(f"{args.prefix}/**", lambda s: inbox.put(
                (str(s.key_expr), s.kind == zenoh.SampleKind.PUT, None, time.time_ns())), history=True)
            log.info("recording %s/** to %s", args.prefix, args.output)
            while not stop.is_set() and (deadline is None or time.monotonic() < deadline):
                _drain(inbox, recorder, timeout=0.1)
            _drain(inbox, recorder, timeout=0.0)
    except RuntimeError as error:
        log.error("%s", error)
        return 1
    finally:
        recorder.finish()
    print(f"recorded {recorder.messages} messages to {args.output}")
    return 0


def _drain(inbox: queue.Queue, recorder: Recorder, timeout: float) -> None:
    try:
        item = inbox.get(timeout=timeout) if timeout else inbox.get_nowait()
    except queue.Empty:
        return
    while True:
        key, payload, encoding, time_ns = item
        if encoding is None:
            recorder.write_liveliness(key, payload, time_ns)
        else:
            recorder.write(key, payload, encoding, time_ns)
        try:
            item = inbox.get_nowait()
        except queue.Empty:
            return


def add_replay(sub: argparse._SubParsersAction) -> None:
    """Register ``gcs replay``."""
    parser = sub.add_parser("replay", help="summarise, republish or process a recording",
                            description="Republish a recording's inputs to Zenoh for a running daemon, or process "
                                        "them directly with the daemon's estimator (--process), or summarise them "
                                        "(--info).")
    parser.add_argument("file", type=Path, metavar="FILE.mcap")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--info", action="store_true", help="print channels, counts, duration and vehicles")
    mode.add_argument("--process", action="store_true", help="run the estimator on the file, without Zenoh")
    mode.add_argument("--rate", type=float, default=1.0, help="republish R times faster than recorded (default 1)")
    mode.add_argument("--fast", action="store_true", help="republish as fast as possible")
    parser.add_argument("--scenario", default=DEFAULT_SCENARIO, help="scenario of the recorded run (--process)")
    parser.add_argument("--out", type=Path, metavar="TRACKS", help="--process: write tracks (.mcap or .csv)")
    parser.add_argument("--plan", action="store_true",
                        help="--process: also plan every step (every GA generation, no deadline); plans go to an "
                             ".mcap --out")
    parser.add_argument("--seed", type=int, default=0, help="--process --plan: the planner's seed (default 0)")
    add_navigation_argument(parser)
    parser.add_argument("--json", action="store_true", help="--info: print JSON")
    parser.add_argument("--view", action="store_true",
                        help="show the recording on the live map (play/pause, speed; --rate is the starting speed, "
                             "--scenario draws the city) until Ctrl-C")
    add_http_argument(parser, "the live map of --view")
    add_foxglove_arguments(parser)
    add_zenoh_arguments(parser, listen=(), connect=(DEFAULT_ENDPOINT,))
    parser.set_defaults(handler=_cmd_replay)


def _cmd_replay(args: argparse.Namespace) -> int:
    try:
        if args.view or args.foxglove_mcap is not None or args.foxglove is not None:
            from gcs.replay_view import cmd_view

            return cmd_view(args, _stop_on_signals)
        if args.info:
            info = summarise(args.file)
            if args.json:
                print(json.dumps(info, indent=2))
            else:
                print(f"{info['file']}: {info['messages']} messages over {info['duration_s']:.1f} s "
                      f"(stamps span {info['stamp_span_s']:.1f} s); vehicles {', '.join(info['vehicles']) or '-'}")
                for channel in info["channels"]:
                    print(f"  {channel['messages']:>8}  {channel['key']}  [{channel['encoding']}]")
            return 0
        if args.process:
            scenario = load_scenario(args.scenario)
            world = build_world(scenario, scenario_base_dir(args.scenario)) if args.plan else None
            tracks, plans, counters = process(args.file, scenario, args.prefix, world, args.seed, args.navigation)
            if args.out is not None:
                write_outputs(tracks, plans, args.out, args.prefix)
            print(f"{len(tracks)} track estimates" + (f" and {len(plans)} plan commands" if args.plan else "")
                  + f" from {args.file}" + (f" -> {args.out}" if args.out else "") + "; "
                  + ", ".join(f"{k} {v}" for k, v in sorted(counters.items())))
            rmse, scored = truth_error(args.file, tracks, round(scenario.time.step_s * NS_PER_S))
            if rmse is not None:
                print(f"RMSE against the recorded truth {rmse:.2f} m over {scored} tracks "
                      f"(--navigation {args.navigation})")
            return 0
        validate_prefix(args.prefix)
        settings = required_settings(args, "republishing")
        if not args.fast and not args.rate > 0:
            raise ValueError(f"--rate must be > 0, got {args.rate}")
        stop = threading.Event()
        _stop_on_signals(stop)
        counts = republish(args.file, settings, args.prefix, None if args.fast else args.rate, stop)
        print("republished " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        return 0
    except (RecordingError, ScenarioError, ValueError, OSError, FoxgloveMissing) as error:
        log.error("%s", error)
        return 2
    except RuntimeError as error:
        log.error("%s", error)
        return 1
