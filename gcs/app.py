"""The ``gcs`` daemon: reports in over Zenoh, the pure tracker step, headings out over MAVLink.

One thread runs the loop and a planner process plans beside it (functional core, imperative
shell: everything that decides is :func:`gcs.core.tracker.fuse` and
:func:`gcs.core.tracker.plan`; this module gathers their inputs and applies their
outputs, always on the loop thread):

1. drain the Zenoh inbox (callbacks only enqueued): validate and count
   (:class:`~gcs.daemon.ingest.Ingest`), file reports into decision steps
   (:class:`~gcs.daemon.steps.StepAssembler`), buffer nav reports for each
   vehicle's navigation filter (:class:`~gcs.daemon.navigation.FleetNavigator`),
   update the vehicle registry from reports, nav reports and liveliness tokens;
2. read MAVLink (heartbeats, telemetry) through the commander;
3. for every decision step that is ready: advance the vehicles' navigation to
   its stamp, fuse every roster vehicle's reports, each from the position its
   navigation gives with that position's covariance
   (:mod:`gcs.daemon.fusion`, the same code ``gcs replay --process`` runs) and
   publish the ``TrackEstimate`` with its k+1..k+n prediction (a pass that drained
   several steps' reports fuses each step as soon as its reports are filed); keep
   the newest step's planning, for the vehicles alive now (a lost vehicle is planned
   without; it rejoins when it returns), from their *reported* positions (an
   autopilot flies its commands from its own navigation, so the plan is made in
   that frame; the navigation filter serves the fusion), and hand it to the planner
   (:mod:`gcs.daemon.planning`) when the planner is free, at most every
   :func:`plan_interval_s` (longer for a large team), so that a plan never holds
   up the reports and tracks behind it;
4. apply the plans the planner has finished: publish each
   ``PlanCommand`` (heading ``psi + u T``, the heading at the end of the step,
   and the planned path) and keep the plan as the next warm start;
5. steer every vehicle along its planned path from its latest MAVLink
   telemetry, :data:`STEER_RATE_HZ` times a second of vehicle time
   (:meth:`Daemon._steer`, :mod:`gcs.core.steering`), and let the commander send
   what is due (GCS heartbeat, stream-rate requests, GUIDED requests through the
   takeover guard, ArduPilot heading commands on change, carrots to PX4); give the
   vehicles back when no vehicle has seen the target for ``handback_after_lost_s``,
   and when the daemon stops (:meth:`Daemon.close`);
6. answer queries, publish ``DaemonStatus`` once a second.

Stop with :meth:`Daemon.stop` (SIGINT/SIGTERM in the CLI): the loop returns and
everything is closed.
"""

from __future__ import annotations

import gc
import logging
import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gcs import __version__
from gcs.adapters.foxglove_out import FoxgloveOptions
from gcs.adapters.mavlink_commands import DEFAULT_STREAM_RATE_HZ, Takeover
from gcs.adapters.mavlink_io import HeadingCommand, MavlinkCommander
from gcs.adapters.recording import Recorder
from gcs.adapters.zenoh_io import ZenohIO
from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints
from gcs.config import Scenario
from gcs.core.geometry import LocalFrame
from gcs.core.kinematics import VehicleState
from gcs.core.filters.prediction import HorizonPrediction
from gcs.core.filters.uif import GaussianEstimate
from gcs.core.steering import SAMPLES_PER_STEP, PlannedPath, course_loop, follow
from gcs.core.tracker import TrackerConfig, prediction
from gcs.daemon.fusion import (FusionDiverged, PlanMemory, fuse_step, plan_commands, track_message,
                               with_observers)
from gcs.core.world import World
from gcs.daemon.ingest import Ingest
from gcs.daemon.planning import PLANNER_NICENESS, Planner, PlanJob, PlanOutcome, start_planner
from gcs.daemon.live import LiveMap
from gcs.daemon.navigation import navigator_for
from gcs.daemon.records import PlanRecord, StepRecord, StepScorer, keep_newest
from gcs.daemon.registry import LOST_AFTER_S, Registry, VehicleSnapshot
from gcs.daemon.steps import ReadyStep, StepAssembler
from gcs.tracking import observer_sensor_model, scenario_planner, subset_config, tracker_config
from protocols.keys import parse_key
from protocols.messages import DaemonStatus, NavReport, SensorReport, TargetTruth, VehicleStatus

__all__ = ["DaemonOptions", "Daemon", "StepRecord", "PlanRecord"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
AUTOPILOT_NAMES = {3: "ArduPilot", 12: "PX4"}
STEER_RATE_HZ = 4.0
"""How often, per second of vehicle time, the steering along the planned paths is recomputed (the carrot
rate). Against vehicles simulated R times faster than real time it runs R times as often in wall time."""
FREEZE_EVERY_S = 1.0
"""How often the loop hands what it has built so far to ``gc.freeze`` (see :meth:`Daemon.run`)."""
FULL_COLLECT_EVERY_S = 600.0
"""How often the loop, when idle, collects everything it froze (any cyclic garbage; the imports' heap too);
a loop never idle does it after twice this."""
PLAN_CHECK_ITEMS = 16
"""While a pass handles what it received, it applies a finished plan after every this many items."""
ALIVE_REFRESH_S = 0.02
"""How long the loop reuses the set of vehicles alive when no liveliness change came in between.

A liveliness token declared or withdrawn is seen at once; what changes without a
liveliness sample (a MAVLink heartbeat that arrives, or one that ages past
``LOST_AFTER_S``, 5 s) is seen within this. Asking every vehicle on every pass
cost the loop a quarter of its time at 100 vehicles, where a pass handles a report
or two."""
MIN_PLAN_INTERVAL_S = 0.05
"""Wall time between two plans handed to the planner, at least (more for a large team: :func:`plan_interval_s`).

The vehicles are steered toward the newest plan :data:`STEER_RATE_HZ` times a
second, so plans made much faster than that are never flown. Live (1 s decision
steps) and in the demo (10x) the planner takes longer than this anyway; against
data arriving hundreds of times faster than real time (``gcs bench daemon``) a
cheap planner (orbit, pursuit) would otherwise cost the loop more in job hand-over
and command publication than the fusion it is there for."""
PLAN_INTERVAL_PER_VEHICLE_S = 0.0025
"""Wall time between two plans for each vehicle planned, at least (see :func:`plan_interval_s`)."""


def plan_interval_s(vehicles: int) -> float:
    """The wall time from one plan's hand-over to the next for a team of ``vehicles``:
    :data:`MIN_PLAN_INTERVAL_S`, or :data:`PLAN_INTERVAL_PER_VEHICLE_S` a vehicle if more, and
    never more than a steering period (``1 / STEER_RATE_HZ``).

    Applying a plan costs the loop about 30 us a vehicle (the job, the outcome, a
    ``PlanCommand`` built, encoded and put for each vehicle: 3 ms at 100 vehicles), and
    reports that arrive meanwhile wait. Against data faster than real time a fast
    planner would otherwise be handed a job every 50 ms whatever the team. Measured at
    100 vehicles and 5,000 reports/s (50 steps a second), plans every 50 ms doubled the
    report-to-track p99 against plans every 2 s (docs/benchmarks.md). With 2.5 ms a
    vehicle, plan application stays near 1% of the loop's time; teams of up to 20
    keep 50 ms, 100 vehicles are planned 4 times a second, as often as they are
    steered. Live, with 1 s decision steps, plans are a step apart anyway.
    """
    return min(max(MIN_PLAN_INTERVAL_S, vehicles * PLAN_INTERVAL_PER_VEHICLE_S), 1.0 / STEER_RATE_HZ)


@dataclass(frozen=True)
class DaemonOptions:
    """How to run the daemon.

    Attributes
    ----------
    zenoh : ZenohSettings
    prefix : str
    mavlink : dict of vehicle id -> connection string, or None for no MAVLink
    signing_key : bytes or None
    seed : int
        Seed of the planner's random generator.
    planner : str or None
        One of :data:`gcs.tracking.PLANNERS`; None takes the scenario's.
    max_wait_s : float
        Wall time a decision step waits for missing vehicles' reports.
    plan_fraction : float
        Share of the planner's deadline it may use (the rest of the step is for
        fusion, visibility maps and I/O).
    record : Path or None
        Record everything received and published to this MCAP file
        (:mod:`gcs.adapters.recording`), finished when the daemon stops.
    planner_mode : str
        Where plans are made (:mod:`gcs.daemon.planning`): ``process`` (the
        default: a child process, so that planning never takes the interpreter
        from the loop), ``thread``, or ``inline`` (in the loop, each plan made when
        it is handed over; deterministic).
    planner_niceness : int
        How much lower the planner process's priority is (0-19; :data:`gcs.daemon.planning.PLANNER_NICENESS`).
    http : (host, port) or None
        Serve the live map there (:mod:`gcs.daemon.live`; port 0 picks a free
        one); None: no page.
    foxglove : FoxgloveOptions or None
        Also send the map to a Foxglove WebSocket server and/or MCAP file.
    accept_unlisted : bool
        Accept reports from vehicles outside the scenario's roster (default: rejected as
        ``unknown_vehicle``); their detections are fused with the scenario's sensor model, and they
        are never planned for or commanded.
    stream_rate_hz : float
        The rate asked of every vehicle for GLOBAL_POSITION_INT and ATTITUDE (0: ask nothing;
        :mod:`gcs.adapters.mavlink_commands`).
    takeover : Takeover
        The guard on switching a vehicle to GUIDED (armed, above an altitude) and the mode it is
        given back in (:class:`~gcs.adapters.mavlink_commands.Takeover`).
    handback_after_lost_s : float
        After this many seconds (stamp time) with no vehicle seeing the target, every vehicle the
        daemon took over is given back; it takes them again when the target is seen again. The
        daemon gives them back when it stops, too.
    navigation : str
        Where a detection's vehicle position comes from (:data:`gcs.daemon.navigation.NAVIGATION_MODES`):
        ``skf`` runs feng2019's SKF on each roster vehicle's ``NavReport``s and fuses with its
        estimate and covariance (steps then wait for the nav reports, :mod:`gcs.daemon.steps`);
        ``reported`` takes the ``SensorReport``'s own position as exact; ``auto`` (the default) is
        ``skf`` for a scenario with GPS-denied zones, else ``reported``
        (:func:`gcs.daemon.navigation.navigator_for`).
    """

    zenoh: ZenohSettings
    prefix: str = "gcs"
    mavlink: dict[str, str] | None = None
    signing_key: bytes | None = None
    seed: int = 0
    planner: str | None = None
    max_wait_s: float = 0.5
    plan_fraction: float = 0.6
    record: Path | None = None
    planner_mode: str = "process"
    planner_niceness: int = PLANNER_NICENESS
    http: tuple[str, int] | None = None
    foxglove: FoxgloveOptions | None = None
    accept_unlisted: bool = False
    navigation: str = "auto"
    stream_rate_hz: float = DEFAULT_STREAM_RATE_HZ
    takeover: Takeover = Takeover()
    handback_after_lost_s: float = 60.0


@dataclass(frozen=True)
class _Planning:
    """What planning a fused step needs, captured when it was fused: the step, the vehicles alive
    then and what was known of them (their states at its stamp come from that), its estimate,
    the k+1..k+n prediction, the planner's clock scale and when (``time.monotonic``); the job
    is built from it when it is handed over."""

    ready: ReadyStep
    active: tuple[str, ...]
    vehicles: VehicleSnapshot
    estimate: GaussianEstimate
    predicted: HorizonPrediction
    clock_scale: float
    fused_s: float


@dataclass
class _Loop:
    """The daemon's mutable memory between steps (estimate, plan, commands)."""

    estimate: GaussianEstimate | None = None
    memory: PlanMemory = field(default_factory=PlanMemory)
    track_seq: int = 0
    plan_seq: int = 0
    last_track_stamp_ns: int | None = None
    last_seen_ns: int | None = None
    """Stamp of the newest decision step in which a vehicle saw the target."""
    target_lost: bool = False
    """No vehicle has seen the target for ``handback_after_lost_s``: the vehicles are given back."""
    step_times: list[tuple[float, int]] = field(default_factory=list)
    paths: dict[str, PlannedPath] = field(default_factory=dict)
    """Each vehicle's newest planned path, which it is steered along."""
    data_rate: float = 1.0
    waiting: _Planning | None = None
    """The newest fused step's planning, until the planner is free to take it."""
    next_plan_s: float = -math.inf


class Daemon:
    """The ground-station loop for one scenario; see the module docstring."""

    def __init__(self, scenario: Scenario, world: World, options: DaemonOptions,
                 clock: Callable[[], float] = time.monotonic, on_step: Callable[[StepRecord], None] | None = None,
                 on_plan: Callable[[PlanRecord], None] | None = None) -> None:
        self.scenario, self.world, self.options = scenario, world, options
        self.clock = clock
        self.on_plan = on_plan
        self.frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        self.roster = [v.id for v in scenario.vehicles]
        self.vehicle_config = {v.id: v for v in scenario.vehicles}
        self.course_loops = {v.id: course_loop(scenario.autopilot_for(v)) for v in scenario.vehicles}
        self.ingest = Ingest(set(self.roster), options.prefix, accept_unlisted=options.accept_unlisted)
        self.steps = StepAssembler(round(scenario.time.step_s * NS_PER_S), options.max_wait_s)
        self.navigator = navigator_for(options.navigation, scenario)
        self.planner_name = options.planner or scenario_planner(scenario)
        self.tracker: TrackerConfig = tracker_config(scenario, world, self.planner_name)
        self._observer_sensor = observer_sensor_model(scenario)
        self.recorder: Recorder | None = None
        self.zenoh = ZenohIO(options.zenoh, options.prefix, tap=self._record_published)
        self.commander: MavlinkCommander | None = None
        self.registry = Registry(list(scenario.vehicles), self._heartbeat_age)
        self.loop = _Loop()
        self.scorer = StepScorer(self.steps.step_ns, clock, on_step)
        self.records: list[StepRecord] = self.scorer.records  # emitted in order, scored when the truth is in
        self.plans: list[PlanRecord] = []
        self.planner: Planner | None = None
        self.counters: Counter = Counter()
        self._stopping = False
        self._started_s = clock()
        self._subset_configs: dict[tuple[int, ...], TrackerConfig] = {}
        self._next_steer_s = 0.0
        self._alive_now: frozenset[str] | None = None  # the vehicles alive (see _alive), asked at _alive_since_s
        self._alive_since_s = 0.0
        self._closed = False
        self._opened = False
        self.live: LiveMap | None = None
        self.zenoh_listening: list[str] = []
        """The endpoints the Zenoh session listens on, once open (a port of 0 read back)."""
        self.mavlink_bound: dict[str, str] = {}
        """Each vehicle's MAVLink connection as bound, once open (a port of 0 read back)."""

    # ------------------------------------------------------------- lifecycle

    def stop(self) -> None:
        """Ask the loop to return (thread- and signal-safe)."""
        self._stopping = True

    def _heartbeat_age(self, vehicle_id: str, now_s: float) -> float | None:
        if self.commander is None:
            return None
        heard = self.commander.link(vehicle_id).last_heartbeat_s
        return None if heard is None else now_s - heard

    def _record_published(self, key: str, payload: bytes, encoding: str, time_ns: int) -> None:
        if self.live is not None:
            self.live.observe_wire(payload, encoding)
        if self.recorder is not None and not key.endswith("/daemon/status"):
            self.recorder.write(key, payload, encoding, time_ns)

    def open(self) -> None:
        """Open the recording, Zenoh, MAVLink and the live map, and start the planner (idempotent: ``run``
        opens if not yet open)."""
        if self._opened:
            return
        self._opened = True
        self.planner = start_planner(self.options.planner_mode, self.scenario, self.world, self.planner_name,
                                     self.options.seed, self._subset, self.options.planner_niceness)
        if self.options.http is not None or self.options.foxglove is not None:
            try:
                self.live = LiveMap.open(self.options.http, self.scenario, self.world,
                                         foxglove=self.options.foxglove)
            except (OSError, RuntimeError) as error:  # the map is for the operator; the vehicles fly without it
                self.counters["errors.live_map_open"] += 1
                log.error("live map off: %s", error)
        if self.options.record is not None:
            self.recorder = Recorder(self.options.record, library=f"gcs {__version__}")
        self.zenoh.open()
        if self.options.mavlink is not None:
            self.commander = MavlinkCommander(
                self.frame, {v.id: v.sysid for v in self.scenario.vehicles}, self.options.mavlink,
                signing_key=self.options.signing_key,
                max_turn_rate_rad_s={v.id: v.max_turn_rate_rad_s for v in self.scenario.vehicles},
                stream_rate_hz=self.options.stream_rate_hz, takeover=self.options.takeover)
        listen = list(self.options.zenoh.listen)
        self.zenoh_listening = listening_endpoints(self.zenoh.session) if any(e.endswith(":0") for e in listen) \
            else listen
        self.mavlink_bound = self.commander.bound_connections() if self.commander is not None else {}
        log.info("daemon up: scenario %s, planner %s, zenoh %s listen %s connect %s, MAVLink %s",
                 self.scenario.name, self.planner_name, self.options.zenoh.mode, self.zenoh_listening,
                 list(self.options.zenoh.connect),
                 ", ".join(f"{v} {c}" for v, c in self.mavlink_bound.items()) or "off")

    def close(self) -> None:
        """Stop the planner, close MAVLink and Zenoh and finish the recording (idempotent).
        The commander's last view stays readable."""
        if self.planner is not None:
            self.planner.close()
        self.scorer.score(flush=True)
        if self.commander is not None and not self._closed:
            self._let_go_all("the daemon stopped")
            self.commander.service(self.clock())  # the hand-backs go out before the links close
            self.commander.close()
        self._closed = True
        if self.live is not None:
            self.live.close()
        self.zenoh.close()
        if self.recorder is not None:
            self.recorder.finish()
            log.info("recorded %d messages to %s", self.recorder.messages, self.recorder.path)

    def run(self, until: Callable[[], bool] | None = None, idle_s: float = 0.001) -> None:
        """Loop until :meth:`stop` (or ``until()`` returns True); always closes what it opened.

        The heap built before the loop is frozen (``gc.freeze``): CPython's full garbage
        collection walks every tracked object, and after the imports (SciPy, pymavlink,
        Zenoh, ...) that is some 75,000 of them and 40-60 ms of CPU, several times a
        minute at thousands of reports a second, holding every report and command behind
        it. Nothing built before the loop becomes cyclic garbage while it runs. What the
        loop keeps (records, estimates, registry entries) is frozen too, every
        :data:`FREEZE_EVERY_S`: at 100 vehicles its older-generation collections otherwise
        took 5-11 ms, a few times a minute. The loop makes no cyclic garbage (none was
        collected over whole ``gcs bench daemon`` runs); in case some path does, the young
        generations are collected before each freeze, and every :data:`FULL_COLLECT_EVERY_S`
        the loop collects everything it froze: when idle, or after twice that if never idle.
        The heap is given back to the collector (``gc.unfreeze``) when the loop ends.
        """
        try:
            self.open()
            gc.freeze()
            next_status = next_freeze = self.clock()
            next_full_collect = next_status + FULL_COLLECT_EVERY_S
            while not self._stopping and (until is None or not until()):
                now = self.clock()
                busy = self.turn(now)
                if now >= next_status:
                    self.zenoh.publish_status(self.status(now))
                    next_status = now + 1.0
                if now >= next_freeze:
                    gc.collect(1)  # the young generations' cycles, if any, before their survivors are frozen
                    gc.freeze()
                    next_freeze = now + FREEZE_EVERY_S
                if now >= next_full_collect and (not busy or now >= next_full_collect + FULL_COLLECT_EVERY_S):
                    gc.unfreeze()
                    gc.collect()
                    gc.freeze()
                    next_full_collect = now + FULL_COLLECT_EVERY_S
                if not busy:  # wake for input, or for a finished plan to command at once
                    self.zenoh.wait(idle_s, until=self.planner.finished)
        finally:
            self.close()
            gc.unfreeze()

    # ------------------------------------------------------------------ loop

    def turn(self, now: float) -> bool:
        """One pass of the loop; True when something was received, fused or planned.

        What was received is handled a step's worth of items (as many as the roster has
        vehicles) at a time, and the steps that completed are fused and published before
        the next are handled (steps that time out go only at the end of the pass): when
        the loop is behind, a step's track does not wait for the reports of the steps
        after it, nor a finished plan's commands for more than :data:`PLAN_CHECK_ITEMS`
        of them. The newest step fused so far waits to be planned
        until the planner is free (:meth:`_hand_over`); an older one waiting is then
        fused only (``steps_fused_only``).
        """
        activity = self._apply_finished_plans()
        received = self.zenoh.drain()
        batch = max(1, len(self.roster))
        newest: _Planning | None = None
        for position, item in enumerate(received, 1):
            try:
                self._handle(item, now)
            except Exception:  # a bug on one input must not take the ground station down
                self.counters["errors.ingest"] += 1
                log.exception("handling %s on %s failed; continuing", item.kind, item.key)
            if position % PLAN_CHECK_ITEMS == 0:  # a finished plan waits for a few reports, not a batch
                activity += self._apply_finished_plans()
            if position % batch == 0 and position < len(received):  # complete steps only: see _release
                newest, done = self._release(now, newest, self._alive(now), timeouts=False)
                activity += done
        if self.commander is not None:
            self.commander.poll(now)  # heartbeats
        newest, done = self._release(now, newest, self._alive(now))
        activity += done
        if newest is not None:
            if self.loop.waiting is not None:
                self.counters["steps_fused_only"] += 1
            self.loop.waiting = newest
        self.scorer.score(flush=False)
        activity += self._apply_finished_plans()
        self._hand_over(now)
        if self.commander is not None:
            if now >= self._next_steer_s:
                self._steer(now)
                self._next_steer_s = now + 1.0 / (STEER_RATE_HZ * self.loop.data_rate)
            self.commander.service(now)
        self.zenoh.answer_queries(status=lambda: self.status(now))
        if self.live is not None:
            self.live.publish(now, lambda: self.status(now))
        return bool(received or activity)

    def _alive(self, now: float) -> frozenset[str]:
        """The roster vehicles alive now (liveliness token or MAVLink heartbeat): asked again after a
        liveliness change, or :data:`ALIVE_REFRESH_S` after the last time."""
        if self._alive_now is None or not self._alive_since_s <= now < self._alive_since_s + ALIVE_REFRESH_S:
            self._alive_now = frozenset(vid for vid in self.roster if self.registry.alive(vid, now))
            self._alive_since_s = now
        return self._alive_now

    def _release(self, now: float, newest: _Planning | None, alive: frozenset[str],
                 timeouts: bool = True) -> tuple[_Planning | None, int]:
        """Fuse and publish every step that is ready, waiting for the ``alive`` vehicles. Returns the
        newest step's planning (``newest`` if none of them can be planned: a step a newer one
        replaces is fused only, ``steps_fused_only``) and how many steps were released and plans
        applied. Without ``timeouts`` only complete steps go: while the pass still holds received
        items, a timed-out step's missing report may be among them."""
        ready = self.steps.ready(alive - self.ingest.off_clock, now, timeouts)
        applied = 0
        for step_ in ready:
            try:
                planning = self._decide(step_, now)
            except FusionDiverged as error:  # absurd data: the previous estimate stands
                self.counters["rejected.diverged"] += 1
                log.warning("decision step %d not fused: %s", step_.index, error)
                planning = None
            except Exception:  # a bug in one step must not take the ground station down
                self.counters["errors.decision"] += 1
                log.exception("decision step %d failed; continuing", step_.index)
                planning = None
            if planning is not None:
                if newest is not None:
                    self.counters["steps_fused_only"] += 1
                newest = planning
            applied += self._apply_finished_plans()
        return newest, len(ready) + applied

    def _handle(self, item, now: float) -> None:
        if self.recorder is not None:
            if item.kind == "sample":
                self.recorder.write(item.key, item.payload, item.encoding, item.received_ns)
            else:
                self.recorder.write_liveliness(item.key, item.kind == "alive", item.received_ns)
        if item.kind in ("alive", "gone"):
            try:
                parsed = parse_key(item.key, self.options.prefix)
            except ValueError:
                self.ingest.reject("key", f"liveliness key {item.key!r}")
                return
            if parsed.kind == "alive" and parsed.ident in self.registry.entries:
                self.registry.on_liveliness(parsed.ident, item.kind == "alive", now)
                self._alive_now = None
                log.info("vehicle %s %s", parsed.ident, "joined" if item.kind == "alive" else "left")
            return
        message = self.ingest.accept(item)
        if self.live is not None:
            self.live.observe(message)
        if isinstance(message, SensorReport):
            if message.vehicle_id in self.registry.entries:  # else a vehicle outside the roster (accept_unlisted)
                self.registry.on_report(message)
            self.steps.add(message, now)
        elif isinstance(message, NavReport):
            if message.vehicle_id in self.registry.entries:
                self.registry.on_nav(message)
                if self.navigator is not None:
                    self.navigator.add(message)
                    self.steps.add_nav(message.vehicle_id, message.stamp_ns)
        elif isinstance(message, TargetTruth):
            self.scorer.add_truth(message.stamp_ns, message.position_enu_m)

    # --------------------------------------------------------------- decision

    def _subset(self, indices: tuple[int, ...]) -> TrackerConfig:
        """The tracker for a subset of the roster (vehicles lost are planned without), cached."""
        config = self._subset_configs.get(indices)
        if config is None:
            config = self._subset_configs[indices] = subset_config(self.tracker, indices)
        return config

    def _decide(self, ready: ReadyStep, now: float) -> _Planning | None:
        """Fuse one step's reports (every roster vehicle's) and publish the track; what planning it for
        the vehicles alive now needs (None when there is nothing to plan)."""
        roster, tracker = with_observers(self.tracker, self.roster, self.ingest.unlisted, self._observer_sensor)
        if self.navigator is not None:
            self.navigator.advance_to(ready.stamp_ns)
        estimate, detections = fuse_step(tracker, self.loop.estimate, ready, roster, self.navigator)
        self.loop.estimate = estimate
        predicted = None
        if estimate is not None:
            predicted = prediction(self.tracker, estimate)  # published with the track, and planned on
            self.loop.track_seq += 1
            self.loop.last_track_stamp_ns = ready.stamp_ns
            contributing = sorted({roster[d.vehicle] for d in detections})
            self.zenoh.publish_track(track_message(self.tracker, estimate, self.scenario.target.id,
                                                   self.scenario.estimator.model, self.loop.track_seq, contributing,
                                                   predicted))
        active = self.registry.plannable(now)
        scale = self._clock_scale(ready, now)
        self._record(ready, active, estimate)
        if not active:
            self.counters["steps_without_vehicles"] += 1
            return None
        if estimate is None:
            return None
        # What is known of the vehicles now: by the time the planner is free, newer reports may be in.
        return _Planning(ready, tuple(active), self.registry.snapshot(active), estimate, predicted, scale,
                         time.monotonic())

    def _hand_over(self, now: float) -> None:
        """Give the newest fused step's planning to the planner once it is not planning (a job handed
        over while it starts replaces the one waiting), and :func:`plan_interval_s` after the last
        hand-over; its job is built now, with the warm start of the plan just applied."""
        planning = self.loop.waiting
        if planning is None or self.planner.planning or now < self.loop.next_plan_s:
            return
        self.loop.waiting = None
        self.loop.next_plan_s = now + plan_interval_s(len(planning.active))
        ready, active, estimate = planning.ready, planning.active, planning.estimate
        self.planner.submit(PlanJob(
            index=ready.index, stamp_ns=ready.stamp_ns, active=active,
            indices=tuple(self.roster.index(v) for v in active),
            state=self.loop.memory.state_for(active, estimate),
            vehicles=planning.vehicles.at(ready.stamp_ns), predicted=planning.predicted,
            clock_scale=planning.clock_scale, submitted_s=planning.fused_s))

    def _apply_finished_plans(self) -> int:
        """Apply what the planner has finished (checked several times a pass, so that a plan waits little)."""
        outcomes = self.planner.take()
        for outcome in outcomes:
            self._apply(outcome)
        return len(outcomes)

    def _apply(self, outcome: PlanOutcome) -> None:
        """A finished plan: keep it as the warm start, command the vehicles, publish the plans."""
        job = outcome.job
        if outcome.error is not None:
            self.counters["errors.planning"] += 1
            return
        self.loop.memory.remember(job.active, outcome.state, outcome.turn_rates)
        self.counters["decisions"] += 1
        self._command(list(job.active), job.vehicles, self._subset(job.indices), outcome.result.controls,
                      job.stamp_ns)
        record = PlanRecord(job.index, job.stamp_ns, job.active, outcome.waited_s, outcome.planning_s,
                            outcome.solve_s, outcome.finished_ns)
        self.plans.append(record)
        keep_newest(self.plans)
        if self.on_plan is not None:
            self.on_plan(record)

    def _clock_scale(self, ready: ReadyStep, now: float) -> float:
        """How much faster than the wall clock the planner's clock runs (data time, over ``plan_fraction``).

        The planner's deadline is a fraction of a decision step of *data* time. Live,
        stamps advance as fast as the wall clock; against vehicles simulated R times
        faster than real time the GA gets 1/R of the wall time, so that its command
        still arrives within the step it was planned for. The rate is measured over
        the last few released steps and never below 1. The deadline is further shrunk
        to ``plan_fraction`` of itself, leaving the rest of the step for fusion and I/O.
        """
        history = self.loop.step_times
        history.append((now, ready.stamp_ns))
        del history[:-6]
        rate = 1.0
        (wall_0, stamp_0), (wall_1, stamp_1) = history[0], history[-1]
        if wall_1 - wall_0 > 1e-3:
            rate = max(1.0, (stamp_1 - stamp_0) / NS_PER_S / (wall_1 - wall_0))
        self.loop.data_rate = rate
        return rate / self.options.plan_fraction

    def _command(self, active: list[str], vehicles: VehicleState, config: TrackerConfig, controls: np.ndarray,
                 stamp_ns: int) -> None:
        dt = self.scenario.time.step_s
        configs = [self.vehicle_config[v] for v in active]
        commands = plan_commands(vehicles, configs, controls, config.max_turn_rate, dt, stamp_ns,
                                 self.loop.plan_seq + 1, self.planner_name)
        self.loop.plan_seq += len(commands)
        for slot, (command, cfg) in enumerate(zip(commands, configs)):
            self.zenoh.publish_plan(command)
            if self.loop.target_lost:
                continue
            start = VehicleState(vehicles.xy[slot:slot + 1], vehicles.heading[slot:slot + 1],
                                 np.array([cfg.speed_mps]), np.array([cfg.altitude_m]))
            self.loop.paths[command.vehicle_id] = PlannedPath.from_plan(start, controls[slot], dt,
                                                                        float(config.max_turn_rate[slot]))

    def _let_go_all(self, why: str) -> None:
        """Stop steering every vehicle; those the daemon took over are given back (:meth:`MavlinkCommander.let_go`)."""
        self.loop.paths.clear()
        if self.commander is not None:
            for vehicle_id in self.roster:
                self.commander.let_go(vehicle_id, why)

    def _watch_target(self, ready: ReadyStep, seen: bool) -> None:
        """Give the vehicles back after ``handback_after_lost_s`` without the target; steer again once seen."""
        if seen:
            self.loop.last_seen_ns = ready.stamp_ns
            if self.loop.target_lost:
                log.info("target seen again at step %d: steering the vehicles", ready.index)
            self.loop.target_lost = False
            return
        last = self.loop.last_seen_ns
        lost_s = None if last is None else (ready.stamp_ns - last) / NS_PER_S
        if lost_s is not None and lost_s >= self.options.handback_after_lost_s and not self.loop.target_lost:
            self.loop.target_lost = True
            self.counters["target_lost"] += 1
            log.warning("no vehicle has seen the target for %.0f s: handing the vehicles back", lost_s)
            self._let_go_all(f"target lost for {lost_s:.0f} s")

    def _steer(self, now: float) -> None:
        """Steer each vehicle along its planned path from its latest MAVLink telemetry (:mod:`gcs.core.steering`).

        The steering is the path follower's, encoded with the lead that makes the course loop of
        the vehicle's autopilot (the one its scenario names) turn at the rate wanted: the course
        an ArduPilot peer is told, and the direction of a PX4 peer's carrot. Following the path from where the vehicle
        is *now* absorbs the delay between the reports a plan was made from and the moment it
        is flown. Without telemetry the plan's course one step on is commanded.
        """
        period = 1.0 / STEER_RATE_HZ
        for vehicle_id, path in self.loop.paths.items():
            link = self.commander.link(vehicle_id)
            course, speed = link.course_rad(), link.ground_speed_mps()
            if link.position_enu_m is None or course is None or speed is None:
                fallback = float(path.courses[min(SAMPLES_PER_STEP, len(path.courses) - 1)])
                self.commander.command(vehicle_id, HeadingCommand(fallback, path.altitude_m, path.airspeed_mps))
                continue
            latency = max(now - link.position_stamp_s, 0.0) * self.loop.data_rate
            steering = follow(path, link.position_enu_m, course, speed, self.course_loops[vehicle_id],
                              period_s=period, latency_s=latency)
            self.commander.command(vehicle_id, HeadingCommand(steering.command_course_rad, path.altitude_m,
                                                              path.airspeed_mps))

    def _record(self, ready: ReadyStep, active: list[str], estimate) -> None:
        """Note what the step did; it is scored against the simulator's truth once that is in (:class:`StepScorer`)."""
        estimate_xy = None if estimate is None else (float(estimate.mean[0]), float(estimate.mean[1]))
        seen = {v: False for v in self.roster}
        for report in ready.reports:
            if report.vehicle_id in seen:
                seen[report.vehicle_id] = seen[report.vehicle_id] or report.detected
        nav_std, fix = {}, {}
        if self.navigator is not None:
            for vehicle_id in self.roster:
                std = self.navigator.horizontal_std_m(vehicle_id)
                if std is not None:
                    nav_std[vehicle_id], fix[vehicle_id] = std, bool(self.navigator.has_fix(vehicle_id))
        record = StepRecord(ready.index, ready.stamp_ns, seen, estimate_xy, None, tuple(active), time.time_ns(),
                            nav_std, fix)
        self.scorer.add(record)
        self._watch_target(ready, any(seen.values()))

    # ----------------------------------------------------------------- status

    def status(self, now: float) -> DaemonStatus:
        """The daemon's health: vehicles, link state, counters, last track."""
        vehicles = []
        for vehicle_id, entry in self.registry.entries.items():
            autopilot = heartbeat = control = None
            if self.commander is not None:
                link = self.commander.link(vehicle_id)
                autopilot = AUTOPILOT_NAMES.get(link.autopilot)
                heartbeat = "unknown" if link.last_heartbeat_s is None else (
                    "ok" if link.alive(now, LOST_AFTER_S) else "lost")
                control = self.commander.control(vehicle_id, now)
            vehicles.append(VehicleStatus(vehicle_id=vehicle_id, sysid=entry.config.sysid,
                                          link=self.registry.link_state(vehicle_id, now),
                                          last_report_stamp_ns=entry.last_report_stamp_ns, reports=entry.reports,
                                          autopilot=autopilot, heartbeat=heartbeat,
                                          liveliness=self.registry.liveliness_state(vehicle_id),
                                          control=control))
        counters = Counter(self.ingest.counters) + self.steps.counters + self.counters
        if self.navigator is not None:
            counters += self.navigator.counters
        if self.planner is not None:
            counters["plans_superseded"] = self.planner.superseded
            counters["planner_restarts"] = getattr(self.planner, "restarts", 0)
        if self.commander is not None:
            counters.update({f"mavlink.{k}": v for k, v in self.commander.counters().items()})
        return DaemonStatus(stamp_ns=time.time_ns(), uptime_s=max(now - self._started_s, 0.0),
                            scenario=self.scenario.name, vehicles=tuple(vehicles),
                            counters={k: int(v) for k, v in counters.items() if v >= 0},
                            last_track_stamp_ns=self.loop.last_track_stamp_ns)
