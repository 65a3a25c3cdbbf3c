"""The ``gcs`` daemon: the shell around the engine, reports in over Zenoh, headings out over MAVLink.

Everything that decides is the :class:`~gcs.engine.engine.Engine` (acceptance, step release,
fusion, what to plan and when, finished plans, the hand-back on a lost target), the same object
``gcs replay --process`` drives from a recording. This module is the imperative shell around it
(functional core, imperative shell), all on one loop thread beside a planner process:

1. drain the Zenoh inbox (callbacks only enqueued), record each item and hand it to the engine
   (:class:`~gcs.engine.events.Arrived`); every roster's worth of items, and at the end of the
   pass, tick the engine (:class:`~gcs.engine.events.Tick`) so that the steps that completed are
   fused and their tracks published before the next items are handled;
2. read MAVLink (heartbeats, telemetry) through the commander, and hand the heartbeats heard to
   the engine (:class:`~gcs.engine.events.Heartbeat`; recorded too);
3. hand the plans the planner finished to the engine (:class:`~gcs.engine.events.PlanDone`),
   several times a pass so that a plan waits little, and tell it when the planner is free
   (:class:`~gcs.engine.events.PlannerFree`): it answers with the job to plan;
4. carry out the engine's actions: publish tracks and plans (and, a member of a federation, its member
   tracks), submit jobs, give vehicles back;
5. steer every vehicle along the path the engine gives it from its latest MAVLink telemetry,
   :data:`STEER_RATE_HZ` times a second of vehicle time (:meth:`Daemon._steer`,
   :mod:`gcs.core.steering`), and let the commander send what is due (GCS heartbeat,
   stream-rate requests, GUIDED requests through the takeover guard, ArduPilot heading commands
   on change, carrots to PX4); give the vehicles back when the daemon stops (:meth:`Daemon.close`);
6. answer queries, publish ``DaemonStatus`` once a second, serve the live map.

Stop with :meth:`Daemon.stop` (SIGINT/SIGTERM in the CLI): the loop returns and
everything is closed.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence

from gcs import __version__
from gcs.adapters.live_map.outputs import LiveMap
from gcs.adapters.mavlink_io import MavlinkCommander
from gcs.adapters.recording import Recorder
from gcs.adapters.zenoh_io import Received, ZenohIO
from gcs.adapters.zenoh_session import listening_endpoints
from gcs.config import Scenario
from gcs.core.filters.iterated import compile_kernel
from gcs.core.geometry import LocalFrame
from gcs.core.steering import PlannedPath, course_loop
from gcs.core.world import World
from gcs.daemon.daemon_status import daemon_status
from gcs.daemon.heap import HeapFreezer
from gcs.daemon.options import DaemonOptions
from gcs.daemon.plan_runners import PlanRunner
from gcs.daemon.plan_runner_start import start_plan_runner
from gcs.daemon.steering import steer_along_paths
from gcs.engine.engine import ALIVE_REFRESH_S, Engine, EngineOptions
from gcs.engine.events import (Action, Arrived, Heartbeat, LetGo, Observed, PlanDone, PlannerFree,
                               PublishMemberTracks, PublishPlan, PublishTrack, RetireTrack, SubmitPlan, Tick)
from gcs.engine.memory import MIN_PLAN_INTERVAL_S, PLAN_INTERVAL_PER_VEHICLE_S, STEER_RATE_HZ, plan_interval_s
from gcs.engine.records import PlanRecord, StepRecord
from protocols.keys import alive_key
from protocols.status import DaemonStatus

__all__ = ["DaemonOptions", "Daemon", "StepRecord", "PlanRecord", "STEER_RATE_HZ", "ALIVE_REFRESH_S",
           "MIN_PLAN_INTERVAL_S", "PLAN_INTERVAL_PER_VEHICLE_S", "plan_interval_s"]

log = logging.getLogger(__name__)

PLAN_CHECK_ITEMS = 16
"""While a pass handles what it received, it applies a finished plan after every this many items."""


class Daemon:
    """The ground-station loop for one scenario: the engine's shell (see the module docstring)."""

    def __init__(self, scenario: Scenario, world: World, options: DaemonOptions,
                 clock: Callable[[], float] = time.monotonic, on_step: Callable[[StepRecord], None] | None = None,
                 on_plan: Callable[[PlanRecord], None] | None = None) -> None:
        self.scenario, self.world, self.options = scenario, world, options
        self.clock = clock
        self.frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        self.engine = Engine(scenario, world, EngineOptions(
            prefix=options.prefix, accept_unlisted=options.accept_unlisted, navigation=options.navigation,
            max_wait_s=options.max_wait_s, planner=options.planner, plan_fraction=options.plan_fraction,
            handback_after_lost_s=options.handback_after_lost_s, federation=options.federation),
            on_step=on_step, on_plan=on_plan)
        self.course_loops = {v.id: course_loop(scenario.autopilot_for(v)) for v in scenario.vehicles}
        self.recorder: Recorder | None = None
        self.zenoh = ZenohIO(options.zenoh, options.prefix, tap=self._record_published, federation=(
            None if options.federation is None else (options.federation.prefix, options.federation.member_id)))
        self.commander: MavlinkCommander | None = None
        self.plan_runner: PlanRunner | None = None
        self._heard: dict[str, float | None] = {}
        self._stopping = False
        self._started_s = clock()
        self._next_steer_s = 0.0
        self._closed = False
        self._opened = False
        self.live: LiveMap | None = None
        self.zenoh_listening: list[str] = []
        """The endpoints the Zenoh session listens on, once open (a port of 0 read back)."""
        self.mavlink_bound: dict[str, str] = {}
        """Each vehicle's MAVLink connection as bound, once open (a port of 0 read back)."""
        self.on_steered: Callable[[float, Sequence[tuple[str, PlannedPath]]], None] | None = None
        """Called after each steering pass with the loop time and the path each vehicle was steered along (the
        benchmarks measure how the vehicles follow them)."""

    # The engine's parts, as the daemon's (status, tests and the live map read them).
    roster = property(lambda self: self.engine.roster)
    ingest = property(lambda self: self.engine.ingest)
    steps = property(lambda self: self.engine.steps)
    navigator = property(lambda self: self.engine.navigator)
    registry = property(lambda self: self.engine.registry)
    loop = property(lambda self: self.engine.loop)
    counters = property(lambda self: self.engine.counters)
    records = property(lambda self: self.engine.records)
    plans = property(lambda self: self.engine.plans)
    planner_name = property(lambda self: self.engine.planner_name)
    tracker = property(lambda self: self.engine.tracker)
    _subset = property(lambda self: self.engine.subset)  # the in-process planners' trackers
    _alive = property(lambda self: self.engine.alive)

    @property
    def on_step(self) -> Callable[[StepRecord], None] | None:
        """Called with each step's record once it is scored (settable after construction: ``gcs demo``)."""
        return self.engine.scorer.on_step

    @on_step.setter
    def on_step(self, hook: Callable[[StepRecord], None] | None) -> None:
        self.engine.scorer.on_step = hook

    @property
    def on_plan(self) -> Callable[[PlanRecord], None] | None:
        """Called with each plan's record once its commands are published (settable after construction)."""
        return self.engine.on_plan

    @on_plan.setter
    def on_plan(self, hook: Callable[[PlanRecord], None] | None) -> None:
        self.engine.on_plan = hook

    # ------------------------------------------------------------- lifecycle

    def stop(self) -> None:
        """Ask the loop to return (thread- and signal-safe)."""
        self._stopping = True

    def _record_published(self, key: str, payload: bytes, encoding: str, time_ns: int) -> None:
        if self.live is not None:
            self.live.observe_wire(payload, encoding)
        if self.recorder is not None and not key.endswith("/daemon/status"):
            self.recorder.write(key, payload, encoding, time_ns)

    def open(self) -> None:
        """Open MAVLink, the live map, the recording and Zenoh, and start the planner (idempotent: ``run``
        opens if not yet open)."""
        if self._opened:
            return
        self._opened = True
        if self.options.mavlink is not None:  # first: a port another program holds is refused before anything starts
            self.commander = MavlinkCommander(
                self.frame, {v.id: v.sysid for v in self.scenario.vehicles}, self.options.mavlink,
                signing_key=self.options.signing_key,
                max_turn_rate_rad_s={v.id: v.max_turn_rate_rad_s for v in self.scenario.vehicles},
                stream_rate_hz=self.options.stream_rate_hz, takeover=self.options.takeover)
        self.plan_runner = start_plan_runner(self.options.plan_runner, self.scenario, self.world, self.planner_name,
                                             self.options.seed, self._subset, self.options.plan_process_niceness,
                                             self.engine.options.autopilot_turn_rates)
        if self.options.http is not None or self.options.foxglove is not None:
            try:
                self.live = LiveMap.open(self.options.http, self.scenario, self.world,
                                         foxglove=self.options.foxglove)
            except (OSError, RuntimeError) as error:  # the map is for the operator; the vehicles fly without it
                self.counters["errors.live_map_open"] += 1
                log.error("live map off: %s", error)
        if self.options.record is not None:
            self.recorder = Recorder(self.options.record, library=f"gcs {__version__}", scenario=self.scenario)
        session = self.zenoh.open()
        listen = list(self.options.zenoh.listen)
        self.zenoh_listening = listening_endpoints(session) if any(e.endswith(":0") for e in listen) else listen
        self.mavlink_bound = self.commander.bound_connections() if self.commander is not None else {}
        compile_kernel()  # with the fast extra, now (about 2 s; what arrives meanwhile waits in the sockets)
        log.info("daemon up: scenario %s, planner %s, zenoh %s listen %s connect %s, MAVLink %s",
                 self.scenario.name, self.planner_name, self.options.zenoh.mode, self.zenoh_listening,
                 list(self.options.zenoh.connect),
                 ", ".join(f"{v} {c}" for v, c in self.mavlink_bound.items()) or "off")

    def close(self) -> None:
        """Stop the planner, close MAVLink and Zenoh and finish the recording (idempotent).
        The commander's last view stays readable."""
        if self.plan_runner is not None:
            self.plan_runner.close()
        self.engine.flush()
        if self.commander is not None and not self._closed:
            self._carry_out([self.engine.let_go_all("the daemon stopped")])
            self.commander.hand_back_before_closing(self.clock())  # answered before the links close
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

        What the loop builds is frozen out of the garbage collector's walks as it goes
        (:class:`~gcs.daemon.heap.HeapFreezer`), and given back to it when the loop ends.
        """
        heap = HeapFreezer()
        try:
            self.open()
            next_status = self.clock()
            heap.start(next_status)
            while not self._stopping and (until is None or not until()):
                now = self.clock()
                busy = self.turn(now)
                if now >= next_status:
                    self.zenoh.publish_status(self.status(now))
                    next_status = now + 1.0
                heap.turn(now, busy)
                if not busy:  # wake for input, or for a finished plan to command at once
                    self.zenoh.wait(idle_s, until=self._runner.finished)
        finally:
            self.close()
            heap.stop()

    # ------------------------------------------------------------------ loop

    @property
    def _runner(self) -> PlanRunner:
        """The plan runner, which :meth:`open` starts."""
        if self.plan_runner is None:
            raise RuntimeError("the daemon is not open: it has no plan runner")
        return self.plan_runner

    def turn(self, now: float) -> bool:
        """One pass of the loop; True when something was received, fused or planned.

        What was received is handled a step's worth of items (as many as the roster has
        vehicles) at a time, and the steps that completed are fused and published before
        the next are handled (steps that time out go only at the end of the pass): when
        the loop is behind, a step's track does not wait for the reports of the steps
        after it, nor a finished plan's commands for more than :data:`PLAN_CHECK_ITEMS`
        of them. The newest step fused so far waits to be planned until the planner is
        free; an older one waiting is then fused only (``steps_fused_only``).
        """
        activity = self._apply_finished_plans()
        received = self.zenoh.drain()
        batch = max(1, len(self.roster))
        for position, item in enumerate(received, 1):
            try:
                self._handle(item, now)
            except Exception:  # a bug on one input must not take the ground station down
                self.counters["errors.ingest"] += 1
                log.exception("handling %s on %s failed; continuing", item.kind, item.key)
            if position % PLAN_CHECK_ITEMS == 0:  # a finished plan waits for a few reports, not a batch
                activity += self._apply_finished_plans()
            if position % batch == 0 and position < len(received):  # complete steps only: see _release
                activity += self._release(now, timeouts=False)
        if self.commander is not None:
            self.commander.poll(now)  # heartbeats
            self._heartbeats(self.commander)
        activity += self._release(now)
        activity += self._apply_finished_plans()
        if not self._runner.planning:
            self._carry_out(self.engine.feed(PlannerFree(now)))
        if now >= self._next_steer_s:
            self._steer(now)
            self._next_steer_s = now + 1.0 / (STEER_RATE_HZ * self.loop.data_rate)
        if self.commander is not None:
            self.commander.service(now)
        self.zenoh.answer_queries(status=lambda: self.status(now))
        if self.live is not None:
            self.live.publish(now, lambda: self.status(now))
        return bool(received or activity)

    def _release(self, now: float, timeouts: bool = True) -> int:
        """Fuse and publish, one at a time, every step that is ready (without ``timeouts`` only complete
        steps go: while the pass still holds received items, a timed-out step's missing report may be
        among them), applying finished plans in between; how many steps and plans that was."""
        done = 0
        tick = Tick(now, timeouts, max_steps=1, wall_ns=time.time_ns(), monotonic_s=time.monotonic())
        while True:
            self._carry_out(self.engine.feed(tick))
            if not self.engine.released:
                break
            done += 1 + self._apply_finished_plans()
            tick = Tick(now, False, max_steps=1, wall_ns=time.time_ns(), monotonic_s=time.monotonic())
        return done

    def _handle(self, item: Received, now: float) -> None:
        if self.recorder is not None:
            if item.kind == "sample":
                self.recorder.write(item.key, item.payload, item.encoding, item.received_ns)
            else:
                self.recorder.write_liveliness(item.key, item.kind == "alive", item.received_ns)
        self._carry_out(self.engine.feed(Arrived(item.kind, item.key, item.payload, item.encoding,
                                                 item.received_ns, now)))

    def _heartbeats(self, commander: MavlinkCommander) -> None:
        """Hand the engine each heartbeat heard since the last pass (and record it)."""
        for vehicle_id in self.roster:
            heard = commander.link(vehicle_id).last_heartbeat_s
            if heard is not None and heard != self._heard.get(vehicle_id):
                self._heard[vehicle_id] = heard
                self.engine.feed(Heartbeat(vehicle_id, heard))
                if self.recorder is not None:
                    self.recorder.write_heartbeat(alive_key(vehicle_id, self.options.prefix), time.time_ns())

    def _apply_finished_plans(self) -> int:
        """Hand the engine what the planner has finished (checked several times a pass, so that a plan waits little)."""
        outcomes = self._runner.take()
        for outcome in outcomes:
            self._carry_out(self.engine.feed(PlanDone(outcome)))
        return len(outcomes)

    def _carry_out(self, actions: list[Action]) -> None:
        """Do what the engine asks."""
        for action in actions:
            if isinstance(action, PublishTrack):
                self.zenoh.publish_track(action.track)
            elif isinstance(action, RetireTrack):
                self.zenoh.retire_track(action.target_id)
            elif isinstance(action, PublishPlan):
                self.zenoh.publish_plan(action.command)
            elif isinstance(action, PublishMemberTracks):
                self.zenoh.publish_member_tracks(action.message)
                if self.live is not None and self.engine.federation is not None:
                    self.live.observe_federation(action, self.engine.federation.picture.members)
            elif isinstance(action, Observed):
                if self.live is not None:
                    self.live.observe(action.message)
            elif isinstance(action, SubmitPlan):
                self._runner.submit(action.job)
            elif isinstance(action, LetGo) and self.commander is not None:
                for vehicle_id in action.vehicle_ids:
                    self.commander.let_go(vehicle_id, action.why)

    def _steer(self, now: float) -> None:
        """Steer each vehicle along the path the engine gives it (:func:`~gcs.daemon.steering.steer_along_paths`)."""
        steered = self.engine.steer()
        if self.commander is not None:
            steer_along_paths(self.commander, steered, self.course_loops, now, self.loop.data_rate)
        if self.on_steered is not None:
            self.on_steered(now, steered)

    # ----------------------------------------------------------------- status

    def status(self, now: float) -> DaemonStatus:
        """The daemon's health (:func:`~gcs.daemon.daemon_status.daemon_status`)."""
        return daemon_status(self.engine, self.scenario.name, self.commander, self.plan_runner,
                             max(now - self._started_s, 0.0), now)
