"""The one loop of the ground station, as an object fed time-stamped inputs that returns actions.

The daemon (:mod:`gcs.daemon.app`), ``gcs replay --process/--plan`` (:mod:`gcs.recordings.replay`) and the
in-process closed loop of ``gcs bench autopilots`` (:mod:`gcs.bench.autopilots`) all drive an
:class:`Engine`; only where the inputs come from (Zenoh and MAVLink, a recording, a simulated
scene) and where the actions go differ (design.md section 2: "one engine"). Everything that
decides lives here, so that live and replayed runs cannot drift apart:

* **acceptance** (:meth:`Engine.feed` of an :class:`~gcs.engine.events.Arrived`): validation and
  counting (:class:`~gcs.engine.ingest.Ingest`, with or without ``accept_unlisted``), the
  vehicle registry (liveliness tokens, MAVLink heartbeats: :class:`~gcs.engine.registry.Registry`),
  decision-step assembly (:class:`~gcs.engine.steps.StepAssembler`, reorder window ``max_wait_s``),
  the vehicles' own navigation (:func:`~gcs.engine.navigation.navigator_for`);
* **step release and fusion** (a :class:`~gcs.engine.events.Tick`): the steps complete for the
  vehicles alive (token or heartbeat; with ``accept_unlisted`` the observers' tokens too; less those
  whose clocks went wrong), or whose wait ran out,
  are fused (:func:`gcs.engine.fusion.fuse_step`, every roster vehicle's reports and the unlisted
  observers') and their tracks published with the k+1..k+n prediction (with ``[multitarget]``, a scan
  of the multi-target tracker, :class:`~gcs.engine.multitarget.TrackKeeper`, and every confirmed
  track published); each is recorded
  (:class:`~gcs.engine.records.StepRecord`) and watched for the target being lost;
* **what to plan and when** (a :class:`~gcs.engine.events.PlannerFree`): the newest fused step,
  for the vehicles alive when it was fused, at most every :func:`~gcs.engine.memory.plan_interval_s`;
* **finished plans** (a :class:`~gcs.engine.events.PlanDone`): the warm start kept, the
  ``PlanCommand`` s published, each vehicle's path to steer along (:meth:`Engine.steer`);
* **the hand-back**: after ``handback_after_lost_s`` of stamps with no vehicle seeing the target (many
  targets: with no track and no lost target to search for) every vehicle is let go
  (:class:`~gcs.engine.events.LetGo`), and steered again once it is seen (there is one again).

No sockets, threads, clocks or global random state: time comes with each input, and the
planner (with its seeded generator) is the shell's, which hands back its outcomes.
"""

from __future__ import annotations

import logging
from collections import Counter, deque
from collections.abc import Callable

import numpy as np

from gcs.config import Scenario
from gcs.core.planner_names import MULTITARGET_PLANNERS
from gcs.core.kinematics import VehicleState
from gcs.core.multitarget.planning import plans_targets
from gcs.core.steering import PlannedPath
from gcs.core.tracker import TrackerConfig, prediction
from gcs.core.world import World
from gcs.engine.fusion import FusionDiverged, fuse_step, plan_commands, track_message, with_observers
from gcs.engine.ingest import MAX_UNLISTED, Ingest
from gcs.engine.navigation import navigator_for
from gcs.engine.plan_jobs import PlanJob, PlanOutcome
from gcs.engine.records import PlanRecord, StepRecord, StepScorer, keep_newest
from gcs.engine.registry import Registry
from gcs.engine.steps import ReadyStep, StepAssembler
from gcs.engine.events import (Action, Arrived, Heartbeat, Input, LetGo, Observed, PlanDone, PlannerFree,
                               PublishPlan, PublishTrack, RetireTrack, SubmitPlan, Tick)
from gcs.engine.memory import CommandAges, LoopMemory, Planning, plan_interval_s
from gcs.engine.multitarget import TrackKeeper
from gcs.engine.options import EngineOptions
from gcs.engine.tracker_factory import observer_sensor_model, scenario_planner, subset_config, tracker_config
from protocols.keys import parse_key
from protocols.messages import NavReport, SensorReport, TargetTruth, TrackEstimate

__all__ = ["EngineOptions", "Engine", "ALIVE_REFRESH_S", "MAX_OBSERVER_TOKENS", "NS_PER_S"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
MAX_OBSERVER_TOKENS = 4 * MAX_UNLISTED
"""Liveliness tokens of vehicles outside the roster remembered (``accept_unlisted``); a flood of made-up
tokens cannot grow the set beyond this."""
ALIVE_REFRESH_S = 0.02
"""How long the engine reuses the set of vehicles alive when no liveliness change came in between.

A liveliness token declared or withdrawn is seen at once; what changes without a
liveliness sample (a MAVLink heartbeat that arrives, or one that ages past
``LOST_AFTER_S``, 5 s) is seen within this. Asking every vehicle on every pass
cost the loop a quarter of its time at 100 vehicles, where a pass handles a report
or two."""


class Engine:
    """The ground-station loop's decisions for one scenario; see the module docstring."""

    def __init__(self, scenario: Scenario, world: World | None, options: EngineOptions = EngineOptions(),
                 on_step: Callable[[StepRecord], None] | None = None,
                 on_plan: Callable[[PlanRecord], None] | None = None) -> None:
        self.scenario, self.options, self.on_plan = scenario, options, on_plan
        self.roster = [v.id for v in scenario.vehicles]
        self.vehicle_config = {v.id: v for v in scenario.vehicles}
        self.ingest = Ingest(set(self.roster), options.prefix, options.accept_unlisted, scenario)
        self.steps = StepAssembler(round(scenario.time.step_s * NS_PER_S), options.max_wait_s)
        self.navigator = navigator_for(options.navigation, scenario)
        self.planner_name = options.planner or scenario_planner(scenario)
        self.tracker: TrackerConfig = tracker_config(scenario, world, self.planner_name)
        self._observer_sensor = observer_sensor_model(scenario)
        self._heard_s: dict[str, float] = {}
        self.registry = Registry(list(scenario.vehicles), self._heartbeat_age)
        self.loop = LoopMemory()
        self.counters: Counter = Counter()
        self._now_s = 0.0
        self.scorer = StepScorer(self.steps.step_ns, lambda: self._now_s, on_step)
        self.records: list[StepRecord] = self.scorer.records  # emitted in order, scored when the truth is in
        self.plans: list[PlanRecord] = []
        self.command_ages = CommandAges()
        self._subset_configs: dict[tuple[int, ...], TrackerConfig] = {}
        self._alive_now: frozenset[str] | None = None  # the vehicles alive (see alive), asked at _alive_since_s
        self._alive_since_s = 0.0
        self._released: deque[ReadyStep] = deque()
        self._observer_tokens: set[str] = set()
        self.keeper = TrackKeeper(scenario, world, self.tracker) if scenario.multitarget is not None else None
        if self.keeper is not None and not plans_targets(self.tracker):
            raise ValueError(f"planner {self.planner_name!r} cannot share the vehicles between targets; "
                             f"scenario {scenario.name!r} has [multitarget] ({', '.join(MULTITARGET_PLANNERS)} can)")
        self.tracks_now: dict[str, TrackEstimate] = {}  # the newest step's tracks by target id

    # ------------------------------------------------------------------ input

    def feed(self, event: Input) -> list[Action]:
        """Take one input; the actions it asks for, in order."""
        if isinstance(event, Arrived):
            return self._arrived(event)
        if isinstance(event, Tick):
            return self._tick(event)
        if isinstance(event, PlanDone):
            return self._plan_done(event.outcome)
        if isinstance(event, PlannerFree):
            return self._hand_over(event.now_s)
        if isinstance(event, Heartbeat):
            if event.vehicle_id in self.registry.entries:
                self._heard_s[event.vehicle_id] = event.heard_s
            return []
        raise TypeError(f"not an engine input: {event!r}")

    def _heartbeat_age(self, vehicle_id: str, now_s: float) -> float | None:
        heard = self._heard_s.get(vehicle_id)
        return None if heard is None else now_s - heard

    def _arrived(self, item: Arrived) -> list[Action]:
        now = self._now_s = item.now_s
        if item.kind in ("alive", "gone"):
            try:
                parsed = parse_key(item.key, self.options.prefix)
            except ValueError:
                self.ingest.reject("key", f"liveliness key {item.key!r}")
                return []
            if parsed.kind == "alive" and parsed.ident in self.registry.entries:
                self.registry.on_liveliness(parsed.ident, item.kind == "alive", now)
                self._alive_now = None
                log.info("vehicle %s %s", parsed.ident, "joined" if item.kind == "alive" else "left")
            elif parsed.kind == "alive" and self.options.accept_unlisted:
                self._observer_token(parsed.ident, item.kind == "alive")
            return []
        admitted = len(self.ingest.unlisted)
        message = self.ingest.accept(item)
        if len(self.ingest.unlisted) != admitted:  # a new observer: steps wait for it if its token is declared
            self._alive_now = None
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
        elif isinstance(message, TargetTruth) and self.keeper is not None:  # the tracks against every target
            self.scorer.add_truth(message.stamp_ns, message.position_enu_m, message.target_id)
        elif isinstance(message, TargetTruth) and message.target_id == self.scenario.target.id:
            self.scorer.add_truth(message.stamp_ns, message.position_enu_m)  # the track is scored against [target]
        return [] if message is None else [Observed(message)]

    def _observer_token(self, vehicle_id: str, declared: bool) -> None:
        """The liveliness token of a vehicle outside the roster (kept for at most :data:`MAX_OBSERVER_TOKENS`)."""
        if declared and len(self._observer_tokens) < MAX_OBSERVER_TOKENS:
            self._observer_tokens.add(vehicle_id)
        elif not declared:
            self._observer_tokens.discard(vehicle_id)
        self._alive_now = None

    def alive(self, now_s: float) -> frozenset[str]:
        """The vehicles a step waits for: the roster's alive now (liveliness token or MAVLink heartbeat) and,
        with ``accept_unlisted``, the observers accepted whose token is declared (their reports are fused:
        whether one is in its step must not depend on when it arrived). Asked again after a liveliness
        change or a new observer, or :data:`ALIVE_REFRESH_S` after the last time."""
        if self._alive_now is None or not self._alive_since_s <= now_s < self._alive_since_s + ALIVE_REFRESH_S:
            self._alive_now = frozenset([vid for vid in self.roster if self.registry.alive(vid, now_s)]
                                        + [vid for vid in self.ingest.unlisted if vid in self._observer_tokens])
            self._alive_since_s = now_s
        return self._alive_now

    # ------------------------------------------------------------- decision

    @property
    def released(self) -> int:
        """Steps released and not yet fused (a :class:`Tick` with ``max_steps`` leaves them for the next)."""
        return len(self._released)

    def _tick(self, tick: Tick) -> list[Action]:
        """Release the ready steps (waiting for the vehicles alive) and fuse up to ``max_steps`` of them."""
        now = self._now_s = tick.now_s
        self._released.extend(self.steps.ready(self.alive(now) - self.ingest.off_clock, now, tick.timeouts))
        actions: list[Action] = []
        count = len(self._released) if tick.max_steps is None else min(tick.max_steps, len(self._released))
        for _ in range(count):
            ready = self._released.popleft()
            try:
                planning = self._decide(ready, tick, actions)
            except FusionDiverged as error:  # absurd data: the previous estimate stands
                self.counters["rejected.diverged"] += 1
                log.warning("decision step %d not fused: %s", ready.index, error)
                planning = None
            except Exception:  # a bug in one step must not take the ground station down
                self.counters["errors.decision"] += 1
                log.exception("decision step %d failed; continuing", ready.index)
                planning = None
            if planning is not None:
                if self.loop.waiting is not None:
                    self.counters["steps_fused_only"] += 1
                self.loop.waiting = planning
        if tick.timeouts:
            self.scorer.score(flush=False)
        return actions

    def subset(self, indices: tuple[int, ...]) -> TrackerConfig:
        """The tracker for a subset of the roster (vehicles lost are planned without), cached."""
        config = self._subset_configs.get(indices)
        if config is None:
            config = self._subset_configs[indices] = subset_config(self.tracker, indices)
        return config

    def _decide(self, ready: ReadyStep, tick: Tick, actions: list[Action]) -> Planning | None:
        """Fuse one step's reports (every roster vehicle's) and publish the track; what planning it for
        the vehicles alive now needs (None when there is nothing to plan)."""
        now = tick.now_s
        roster, tracker = with_observers(self.tracker, self.roster, self.ingest.unlisted, self._observer_sensor)
        if self.navigator is not None:
            self.navigator.advance_to(ready.stamp_ns)
        estimate = predicted = targets = seen = None
        tracks: tuple[TrackEstimate, ...] = ()
        if self.keeper is not None:  # every target: the multi-target tracker's confirmed tracks
            scanned = self.keeper.scan(ready, roster, tracker, self.loop.track_seq + 1, self.navigator)
            tracks, targets, seen = scanned.tracks, self.keeper.targets(), scanned.detected
            current = {track.target_id: track for track in tracks}
            actions.extend(RetireTrack(target_id) for target_id in self.tracks_now if target_id not in current)
            self.tracks_now = current
        else:
            estimate, detections = fuse_step(tracker, self.loop.estimate, ready, roster, self.navigator)
            self.loop.estimate = estimate
            if estimate is not None:
                predicted = prediction(self.tracker, estimate)  # published with the track, and planned on
                contributing = sorted({roster[d.vehicle] for d in detections})
                tracks = (track_message(self.tracker, estimate, self.scenario.target.id,
                                        self.scenario.estimator.model, self.loop.track_seq + 1, contributing,
                                        predicted),)
                self.tracks_now = {tracks[0].target_id: tracks[0]}
        if tracks:
            self.loop.track_seq += 1
            self.loop.last_track_stamp_ns = ready.stamp_ns
            actions.extend(PublishTrack(track) for track in tracks)
        active = self.registry.plannable(now)
        scale = self.loop.clock_scale(now, ready.stamp_ns, self.options.plan_fraction)
        seen_any = self._record(ready, active, estimate, tick.wall_ns, seen,
                                None if self.keeper is None else tuple((t.state[0], t.state[1]) for t in tracks))
        # Many targets: the vehicles are given back once there has been nothing to track or search for.
        actions.extend(self.watch_target(ready, seen_any if self.keeper is None else targets is not None))
        if not active:
            self.counters["steps_without_vehicles"] += 1
            return None
        if estimate is None and targets is None:
            return None
        # What is known of the vehicles now: by the time the planner is free, newer reports may be in.
        return Planning(ready, tuple(active), self.registry.snapshot(active), estimate, predicted, scale,
                        tick.monotonic_s, targets)

    def _record(self, ready: ReadyStep, active: list[str], estimate, wall_ns: int,
                detected: dict[str, bool] | None = None, tracks_xy: tuple | None = None) -> bool:
        """Note what the step did; it is scored against the simulator's truth once that is in (:class:`StepScorer`).

        A vehicle saw the target when one of its reports has a detection, or, given ``detected`` (many
        targets), when its detections were associated with a confirmed track. True when one did."""
        estimate_xy = None if estimate is None else (float(estimate.mean[0]), float(estimate.mean[1]))
        seen = {v: detected.get(v, False) if detected is not None else False for v in self.roster}
        for report in ready.reports if detected is None else ():
            if report.vehicle_id in seen:
                seen[report.vehicle_id] = seen[report.vehicle_id] or report.detected
        nav_std, fix = {}, {}
        if self.navigator is not None:
            for vehicle_id in self.roster:
                std = self.navigator.horizontal_std_m(vehicle_id)
                if std is not None:
                    nav_std[vehicle_id], fix[vehicle_id] = std, bool(self.navigator.has_fix(vehicle_id))
        self.scorer.add(StepRecord(ready.index, ready.stamp_ns, seen, estimate_xy, None, tuple(active), wall_ns,
                                   nav_std, fix, tracks_xy))
        return any(seen.values())

    def watch_target(self, ready: ReadyStep, seen: bool) -> list[Action]:
        """Give the vehicles back after ``handback_after_lost_s`` without the target; steer again once seen."""
        if seen:
            self.loop.last_seen_ns = ready.stamp_ns
            if self.loop.target_lost:
                log.info("target seen again at step %d: steering the vehicles", ready.index)
            self.loop.target_lost = False
            return []
        last = self.loop.last_seen_ns
        lost_s = None if last is None else (ready.stamp_ns - last) / NS_PER_S
        if lost_s is not None and lost_s >= self.options.handback_after_lost_s and not self.loop.target_lost:
            self.loop.target_lost = True
            self.counters["target_lost"] += 1
            what = "the target" if self.keeper is None else "a target (nor had one to search for)"
            log.warning("no vehicle has seen %s for %.0f s: handing the vehicles back", what, lost_s)
            return [self.let_go_all(f"target lost for {lost_s:.0f} s")]
        return []

    def let_go_all(self, why: str) -> LetGo:
        """Stop steering every vehicle; the action that gives back those taken over."""
        self.loop.paths.clear()
        self.loop.path_stamps_ns.clear()
        return LetGo(tuple(self.roster), why)

    # ------------------------------------------------------------- planning

    def _hand_over(self, now: float) -> list[Action]:
        """Give the newest fused step's planning to the (free) planner, :func:`plan_interval_s` after the
        last hand-over; its job is built now, with the warm start of the plan just applied."""
        planning = self.loop.waiting
        if planning is None or now < self.loop.next_plan_s:
            return []
        self.loop.waiting = None
        if not self.options.plan_every_step:
            self.loop.next_plan_s = now + plan_interval_s(len(planning.active))
        ready, active, estimate = planning.ready, planning.active, planning.estimate
        return [SubmitPlan(PlanJob(
            index=ready.index, stamp_ns=ready.stamp_ns, active=active,
            indices=tuple(self.roster.index(v) for v in active),
            state=self.loop.memory.state_for(active, estimate),
            vehicles=planning.vehicles.at(ready.stamp_ns), predicted=planning.predicted,
            clock_scale=planning.clock_scale, submitted_s=planning.fused_s, targets=planning.targets))]

    def _plan_done(self, outcome: PlanOutcome) -> list[Action]:
        """A finished plan: keep it as the warm start, publish the plans, steer the vehicles along them."""
        job = outcome.job
        if outcome.error is not None:
            self.counters["errors.planning"] += 1
            return []
        self.loop.memory.remember(job.active, outcome.state, outcome.turn_rates)
        self.counters["decisions"] += 1
        actions = self._command(list(job.active), job.vehicles, self.subset(job.indices), outcome.result.controls,
                                job.stamp_ns)
        record = PlanRecord(job.index, job.stamp_ns, job.active, outcome.waited_s, outcome.planning_s,
                            outcome.solve_s, outcome.finished_ns)
        self.plans.append(record)
        keep_newest(self.plans)
        if self.on_plan is not None:
            self.on_plan(record)
        return actions

    def _command(self, active: list[str], vehicles: VehicleState, config: TrackerConfig, controls: np.ndarray,
                 stamp_ns: int) -> list[Action]:
        dt = self.scenario.time.step_s
        configs = [self.vehicle_config[v] for v in active]
        commands = plan_commands(vehicles, configs, controls, config.max_turn_rate, dt, stamp_ns,
                                 self.loop.plan_seq + 1, self.planner_name)
        self.loop.plan_seq += len(commands)
        actions: list[Action] = []
        for slot, (command, cfg) in enumerate(zip(commands, configs)):
            actions.append(PublishPlan(command))
            if self.loop.target_lost:
                continue
            start = VehicleState(vehicles.xy[slot:slot + 1], vehicles.heading[slot:slot + 1],
                                 np.array([cfg.speed_mps]), np.array([cfg.altitude_m]))
            self.loop.paths[command.vehicle_id] = PlannedPath.from_plan(start, controls[slot], dt,
                                                                        float(config.max_turn_rate[slot]))
            self.loop.path_stamps_ns[command.vehicle_id] = stamp_ns
        return actions

    # ------------------------------------------------------------- steering

    def steer(self) -> list[tuple[str, PlannedPath]]:
        """The vehicles to steer now and the path each follows; each such command's age is measured at the
        vehicle time it goes out (the newest accepted stamp: :class:`~gcs.engine.memory.CommandAges`)."""
        flown_ns = self.ingest.newest_ns
        if flown_ns is not None:
            for vehicle_id in self.loop.paths:
                self.command_ages.add(flown_ns, self.loop.path_stamps_ns[vehicle_id])
        return list(self.loop.paths.items())

    def flush(self) -> None:
        """Emit every step record still waiting for its truth (the run is over)."""
        self.scorer.score(flush=True)

    def counters_now(self) -> Counter:
        """Every counter of the engine's parts: ingest, steps, navigation and its own."""
        counters = Counter(self.ingest.counters) + self.steps.counters + self.counters
        if self.navigator is not None:
            counters += self.navigator.counters
        return counters
