"""The one loop of the ground station, as an object fed time-stamped inputs that returns actions.

The daemon (:mod:`gcs.daemon.app`), ``gcs replay --process/--plan`` (:mod:`gcs.recordings.replay`) and the
benchmarks' closed loops (``gcs-bench``, a simulated scene in one process) all drive an
:class:`Engine`; only where the inputs come from (Zenoh and MAVLink, a recording, a simulated
scene) and where the actions go differ (docs/design.md, the layers: "one engine"). Everything that
decides lives here, so that live and replayed runs cannot drift apart:

* **acceptance** (:meth:`Engine.feed` of an :class:`~gcs.engine.events.Arrived`,
  :class:`~gcs.engine.acceptance.Acceptance`): validation and counting
  (:class:`~gcs.engine.ingest.Ingest`, with or without ``accept_unlisted``), the vehicle registry
  (liveliness tokens, MAVLink heartbeats: :class:`~gcs.engine.registry.Registry`), decision-step
  assembly (:class:`~gcs.engine.steps.StepAssembler`, reorder window ``max_wait_s``), the vehicles'
  own navigation (:func:`~gcs.engine.navigation.navigator_for`);
* **step release and fusion** (a :class:`~gcs.engine.events.Tick`): the steps complete for the
  vehicles alive (token or heartbeat; with ``accept_unlisted`` the observers' tokens too; less those
  whose clocks went wrong), or whose wait ran out,
  are fused (:func:`gcs.engine.fusion.fuse_step`, every roster vehicle's reports and the unlisted
  observers') and their tracks published with the k+1..k+n prediction (with ``[multitarget]``, a scan
  of the multi-target tracker, :class:`~gcs.engine.multitarget.TrackKeeper`, and every confirmed
  track published); each is recorded
  (:class:`~gcs.engine.records.StepRecord`) and watched for the target being lost;
* **what to plan and when** (a :class:`~gcs.engine.events.PlannerFree`): the newest fused step,
  for the vehicles alive when it was fused, at most every :func:`~gcs.engine.memory.plan_interval_s`
  (:class:`~gcs.engine.hand_over.PlanHandOver`);
* **finished plans** (a :class:`~gcs.engine.events.PlanDone`): the warm start kept, the
  ``PlanCommand`` s published, each vehicle's path to steer along (:meth:`Engine.steer`);
* **a federation** (``options.federation``, :mod:`gcs.engine.federation`): the other members' tracks and
  liveliness are taken in, each scan's confirmed tracks are named and fused into the federation's picture
  and published (:class:`~gcs.engine.federation.PublishMemberTracks`), and the vehicles are planned for the
  targets the picture gives this member;
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

from gcs.config import Scenario
from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.multitarget.planning import plans_targets
from gcs.core.planner_names import MULTITARGET_PLANNERS
from gcs.core.steering import PlannedPath
from gcs.core.tracker import TrackerConfig, prediction
from gcs.core.world import World
from gcs.engine.acceptance import ALIVE_REFRESH_S, MAX_OBSERVER_TOKENS, NS_PER_S, Acceptance
from gcs.engine.events import (Action, Arrived, Heartbeat, Input, LetGo, Observed, PlanDone, PlannerFree,
                               PublishTrack, RetireTrack, Tick)
from gcs.engine.federation import FederationMember
from gcs.engine.fusion import FusionDiverged, fuse_step, track_message, with_observers
from gcs.engine.hand_over import PlanHandOver
from gcs.engine.memory import CommandAges, LoopMemory, Planning
from gcs.engine.multitarget import TrackKeeper
from gcs.engine.options import EngineOptions
from gcs.engine.plan_jobs import PlanOutcome
from gcs.engine.records import PlanRecord, StepRecord, StepScorer, keep_newest
from gcs.engine.steps import ReadyStep
from gcs.engine.tracker_factory import observer_sensor_model, scenario_planner, tracker_config
from protocols.messages import TargetTruth, TrackEstimate

__all__ = ["EngineOptions", "Engine", "ALIVE_REFRESH_S", "MAX_OBSERVER_TOKENS", "NS_PER_S"]

log = logging.getLogger(__name__)


class Engine:
    """The ground-station loop's decisions for one scenario; see the module docstring."""

    def __init__(self, scenario: Scenario, world: World | None, options: EngineOptions = EngineOptions(),
                 on_step: Callable[[StepRecord], None] | None = None,
                 on_plan: Callable[[PlanRecord], None] | None = None) -> None:
        self.scenario, self.options, self.on_plan = scenario, options, on_plan
        self.acceptance = Acceptance(scenario, options)
        self.roster = self.acceptance.roster
        self.ingest, self.steps, self.registry = self.acceptance.ingest, self.acceptance.steps, self.acceptance.registry
        self.navigator = self.acceptance.navigator
        self.alive = self.acceptance.alive
        self.planner_name = options.planner or scenario_planner(scenario)
        self.tracker: TrackerConfig = tracker_config(scenario, world, self.planner_name,
                                                     autopilot_turn_rates=options.autopilot_turn_rates)
        self._observer_sensor = observer_sensor_model(scenario)
        self.loop = LoopMemory()
        self.counters: Counter[str] = Counter()
        self.plan_hand_over = PlanHandOver(scenario, options, self.tracker, self.planner_name, self.loop,
                                           self.counters)
        self.subset = self.plan_hand_over.subset
        self._now_s = 0.0
        self.scorer = StepScorer(self.steps.step_ns, lambda: self._now_s, on_step)
        self.records: list[StepRecord] = self.scorer.records  # emitted in order, scored when the truth is in
        self.plans: list[PlanRecord] = []
        self.command_ages = CommandAges()
        self._released: deque[ReadyStep] = deque()
        self.keeper = TrackKeeper(scenario, world, self.tracker) if scenario.multitarget is not None else None
        if self.keeper is not None and not plans_targets(self.tracker):
            raise ValueError(f"planner {self.planner_name!r} cannot share the vehicles between targets; "
                             f"scenario {scenario.name!r} has [multitarget] ({', '.join(MULTITARGET_PLANNERS)} can)")
        self.tracks_now: dict[str, TrackEstimate] = {}  # the newest step's tracks by target id
        self.federation: FederationMember | None = None
        if options.federation is not None:
            if self.keeper is None:
                raise ValueError(f"a federation member tracks many targets: scenario {scenario.name!r} needs a "
                                 "[multitarget] table")
            assert scenario.multitarget is not None  # (the keeper exists)
            self.federation = FederationMember(options.federation, self.keeper.motion,
                                               scenario.multitarget.starvation_s, self.counters)

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
            return self.plan_hand_over.hand_over(event.now_s)
        if isinstance(event, Heartbeat):
            self.acceptance.heartbeat(event)
            return []
        raise TypeError(f"not an engine input: {event!r}")

    def _arrived(self, item: Arrived) -> list[Action]:
        self._now_s = item.now_s
        if self.federation is not None and self.federation.owns(item.key):
            self.federation.arrived(item.kind, item.key, item.payload, item.encoding)
            return []
        message = self.acceptance.arrived(item)
        if isinstance(message, TargetTruth) and self.keeper is not None:  # the tracks against every target
            self.scorer.add_truth(message.stamp_ns, message.position_enu_m, message.target_id)
        elif isinstance(message, TargetTruth) and message.target_id == self.scenario.target.id:
            self.scorer.add_truth(message.stamp_ns, message.position_enu_m)  # the track is scored against [target]
        return [] if message is None else [Observed(message)]

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

    def _decide(self, ready: ReadyStep, tick: Tick, actions: list[Action]) -> Planning | None:
        """Fuse one step's reports (every roster vehicle's) and publish the track; what planning it for
        the vehicles alive now needs (None when there is nothing to plan)."""
        now = tick.now_s
        roster, tracker = with_observers(self.tracker, self.roster, self.ingest.unlisted, self._observer_sensor)
        if self.navigator is not None:
            self.navigator.advance_to(ready.stamp_ns)
        estimate = predicted = targets = seen = None
        tracks: tuple[TrackEstimate, ...] = ()
        active = self.registry.plannable(now)
        if self.keeper is not None:  # every target: the multi-target tracker's confirmed tracks
            scanned = self.keeper.scan(ready, roster, tracker, self.loop.track_seq + 1, self.navigator)
            tracks, targets, seen = scanned.tracks, self.keeper.targets(), scanned.detected
            current = {track.target_id: track for track in tracks}
            actions.extend(RetireTrack(target_id) for target_id in self.tracks_now if target_id not in current)
            self.tracks_now = current
            if self.federation is not None:  # the federation's picture decides what this team plans for
                team = [p for v in active if (p := self.registry.entries[v].position_enu_m)]
                published, targets = self.federation.after_scan(ready.stamp_ns, self.keeper.own_tracks(), team,
                                                                tracker)
                actions.append(published)
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

    def _record(self, ready: ReadyStep, active: list[str], estimate: GaussianEstimate | None, wall_ns: int,
                detected: dict[str, bool] | None = None,
                tracks_xy: tuple[tuple[float, float], ...] | None = None) -> bool:
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

    def _plan_done(self, outcome: PlanOutcome) -> list[Action]:
        """A finished plan (:meth:`PlanHandOver.finished <gcs.engine.hand_over.PlanHandOver.finished>`), recorded."""
        actions, record = self.plan_hand_over.finished(outcome)
        if record is not None:
            self.plans.append(record)
            keep_newest(self.plans)
            if self.on_plan is not None:
                self.on_plan(record)
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

    def counters_now(self) -> Counter[str]:
        """Every counter of the engine's parts: ingest, steps, navigation and its own."""
        counters = Counter(self.ingest.counters) + self.steps.counters + self.counters
        if self.navigator is not None:
            counters += self.navigator.counters
        return counters
