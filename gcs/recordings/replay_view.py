"""``gcs replay FILE --view``: a recording on the live map, with play/pause and speed.

The server side keeps the clock (:class:`ReplayClock`): the replay position is
recording time (receive time, ``log_time``, from the first message) that
advances with wall time multiplied by the speed while playing. The loop feeds
the :class:`~gcs.adapters.live_map.picture.Picture` every recorded message up to the
position, in file order, exactly as the daemon's map is fed live (the
recorded inputs, the daemon's published tracks and plans, the simulator's
truth, liveliness), and publishes a snapshot at most five times a second. The
page's buttons ``POST /api/replay`` (:meth:`ReplayClock.control`): play,
pause, restart (from the beginning, with an empty picture) and speed. At the
end of the file the clock pauses; play after the end restarts.
"""

from __future__ import annotations

import argparse
import logging
import math
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader

from gcs.adapters.foxglove_out import FoxgloveOptions, FoxgloveOut, foxglove_options
from gcs.adapters.recording import HEARTBEAT_ENCODING, LIVELINESS_ENCODING, read_recording
from gcs.cli_errors import stop_on_signals
from gcs.config import Scenario
from gcs.config.world import build_world
from gcs.core.world import World
from gcs.adapters.live_map.outputs import LiveMap
from gcs.adapters.live_map.picture import Picture
from gcs.recordings.replay import key_kind
from gcs.scenarios import load_scenario, scenario_base_dir

__all__ = ["ReplayClock", "view", "to_foxglove", "cmd_view", "recording_span_ns", "MAX_SPEED"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
MAX_SPEED = 1000.0
"""Fastest replay the controls accept (multiples of the recorded pace)."""
TICK_S = 0.02


def recording_span_ns(path: Path) -> int | None:
    """log_time span of a recording from its summary; None when it has none (its writer was killed)."""
    try:
        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
    except (McapError, ValueError, OSError, EOFError):
        return None
    if summary is None or summary.statistics is None or not summary.statistics.message_count:
        return None
    return summary.statistics.message_end_time - summary.statistics.message_start_time


class ReplayClock:
    """The replay position in recording time; controlled from the HTTP threads, read by the replay loop.

    While playing, ``position = base + (wall - wall_at_base) * speed``; every
    change of state re-bases, so a change of speed never makes the position jump.
    """

    def __init__(self, speed: float, duration_ns: int | None, wall: Callable[[], float] = time.monotonic) -> None:
        self.duration_ns, self.wall = duration_ns, wall
        self.speed = self._checked_speed(speed)
        self.playing, self.ended = True, False
        self._base_ns, self._base_wall = 0.0, wall()
        self._restart = False
        self._lock = threading.Lock()

    @staticmethod
    def _checked_speed(speed: object) -> float:
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not math.isfinite(speed) \
                or not 0 < speed <= MAX_SPEED:
            raise ValueError(f"speed must be a number in (0, {MAX_SPEED:g}], got {speed!r}")
        return float(speed)

    def _rebase(self) -> None:
        now = self.wall()
        if self.playing:
            self._base_ns += (now - self._base_wall) * self.speed * NS_PER_S
        self._base_wall = now

    def position_ns(self) -> int:
        """Recording time reached, ns from the first message."""
        with self._lock:
            if not self.playing:
                return round(self._base_ns)
            return round(self._base_ns + (self.wall() - self._base_wall) * self.speed * NS_PER_S)

    def control(self, request: dict) -> dict:
        """Apply ``{"action": "play"|"pause"|"toggle"|"restart", "speed": R}`` (either key optional).

        Raises ValueError (answered 400) for an unknown action or a bad speed;
        returns the new :meth:`view`.
        """
        unknown = set(request) - {"action", "speed"}
        if unknown:
            raise ValueError(f"unknown keys {sorted(unknown)}; expected action and/or speed")
        action = request.get("action")
        if action not in (None, "play", "pause", "toggle", "restart"):
            raise ValueError(f"action must be play, pause, toggle or restart, got {action!r}")
        speed = self._checked_speed(request["speed"]) if "speed" in request else None
        with self._lock:
            self._rebase()
            if speed is not None:
                self.speed = speed
            if action == "toggle":
                action = "pause" if self.playing else "play"
            if action == "play" and self.ended or action == "restart":
                self._restart, self.ended, self._base_ns = True, False, 0.0
                self.playing = True
            elif action in ("play", "pause"):
                self.playing = action == "play"
        log.info("replay %s", request)
        return self.view()

    def finish(self) -> None:
        """The recording is exhausted: pause at its end."""
        with self._lock:
            if not self.ended:
                self._rebase()
                self.playing, self.ended = False, True

    def take_restart(self) -> bool:
        """True once after a restart was asked for."""
        with self._lock:
            restart, self._restart = self._restart, False
            return restart

    def view(self) -> dict:
        """The clock for the page: playing, speed, position and duration (s), ended."""
        position = self.position_ns()
        with self._lock:
            return {"playing": self.playing, "speed": self.speed, "position_s": round(position / NS_PER_S, 2),
                    "duration_s": None if self.duration_ns is None else round(self.duration_ns / NS_PER_S, 2),
                    "ended": self.ended}


def view(path: Path, scenario: Scenario, world: World, address: tuple[str, int] | None, speed: float,
         stop: threading.Event, on_open: Callable[[LiveMap], None] | None = None, tick_s: float = TICK_S,
         foxglove: FoxgloveOptions | None = None) -> Counter:
    """Serve the recording on the live map (and to Foxglove) until ``stop`` is set; returns counts of what was fed.

    ``on_open(live)`` is called once the page is being served. Raises OSError
    when the address cannot be bound and :class:`~gcs.adapters.recording.RecordingError`
    for a corrupt file (the server is closed either way).
    """
    clock = ReplayClock(speed, recording_span_ns(path))
    live = LiveMap.open(address, scenario, world, mode="replay", control=clock.control, foxglove=foxglove)
    counts: Counter = Counter()
    try:
        if on_open is not None:
            on_open(live)
        while not stop.is_set():
            live.picture = Picture(scenario, world, mode="replay")
            counts += _play(path, clock, live, stop, tick_s)
    finally:
        live.close()
    return counts


def _play(path: Path, clock: ReplayClock, live: LiveMap, stop: threading.Event, tick_s: float) -> Counter:
    """One pass over the file, until its end and a restart, or ``stop``; counts of what was fed."""
    counts: Counter = Counter()
    records = read_recording(path)
    try:
        pending = next(records, None)
        first = 0 if pending is None else pending.log_time_ns
        while not stop.is_set() and not clock.take_restart():
            position = clock.position_ns()
            while pending is not None and pending.log_time_ns - first <= position:
                _feed(live.picture, pending, counts)
                pending = next(records, None)
            if pending is None:
                clock.finish()
            live.publish(time.monotonic(), extra={"replay": clock.view()})
            stop.wait(tick_s)
    finally:
        records.close()
    return counts


def _feed(picture: Picture, record, counts: Counter) -> None:
    kind, ident = key_kind(record.key)
    counts[kind or "other"] += 1
    picture.counters[f"replayed.{kind or 'other'}"] = counts[kind or "other"]
    if record.encoding == LIVELINESS_ENCODING:
        if kind == "alive" and ident is not None:
            picture.on_liveliness(ident, record.payload == b"alive")
        return
    if record.encoding == HEARTBEAT_ENCODING:  # the daemon's MAVLink heartbeats: not wire messages to draw
        return
    picture.observe_wire(record.payload, record.encoding)


def to_foxglove(path: Path, scenario: Scenario, world: World, out: Path, every_s: float = 0.2) -> Counter:
    """Convert a recording into an MCAP file of Foxglove's map schemas (:mod:`gcs.adapters.foxglove_out`).

    The picture is fed every message in file order, as fast as possible, and a
    snapshot is logged for every ``every_s`` of stamp time, with that stamp as
    its log time, so the map's timeline is the data's; a last one holds what came
    in after it (the tracks of the last step come after its reports, at its stamp).
    """
    picture = Picture(scenario, world, mode="replay")
    sink = FoxgloveOut(picture.frame, picture.world, FoxgloveOptions(mcap=out))
    counts: Counter = Counter()
    step_ns, logged_ns = round(every_s * NS_PER_S), None
    try:
        fed_since_log = False
        for record in read_recording(path):
            _feed(picture, record, counts)
            fed_since_log = True
            newest = picture.newest_ns
            if newest is not None and (logged_ns is None or newest - logged_ns >= step_ns):
                sink.log(*picture.snapshot(), log_time_ns=newest)
                logged_ns, fed_since_log = newest, False
        if picture.newest_ns is not None and fed_since_log:  # what came in at the last stamp (a step's tracks)
            sink.log(*picture.snapshot(), log_time_ns=picture.newest_ns)
        counts["foxglove_messages"] = sink.messages
    finally:
        sink.close()
    return counts


def cmd_view(args: argparse.Namespace) -> int:
    """``gcs replay FILE --view`` and ``--foxglove-mcap OUT`` (called by :mod:`gcs.recordings.replay_cli`'s command once it
    has checked the options)."""
    foxglove = foxglove_options(args)
    scenario = load_scenario(args.scenario)
    world = build_world(scenario, scenario_base_dir(args.scenario))
    if not args.view:
        counts = to_foxglove(args.file, scenario, world, args.foxglove_mcap)
        print(f"wrote {args.foxglove_mcap}: {counts['foxglove_messages']} map messages from "
              + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()) if k != "foxglove_messages"))
        return 0
    stop = threading.Event()
    stop_on_signals(stop.set)

    def opened(live) -> None:
        print(f"live map: {live.url or 'off'} (replaying {args.file}; Ctrl-C to stop)", flush=True)
        if live.foxglove is not None:
            print(f"foxglove: {live.foxglove.url or 'no server'}", flush=True)

    counts = view(args.file, scenario, world, args.http, args.rate, stop, on_open=opened, foxglove=foxglove)
    print("shown " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return 0
