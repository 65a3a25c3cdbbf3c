"""``sim-vehicles run``: the scene in (scaled) real time, on MAVLink and Zenoh.

Each physics step of simulation time ``dt`` the runner

1. hands every received MAVLink message to the vehicle it is addressed to
   (its autopilot personality, :mod:`sim_vehicles.personalities`) and sends the replies;
2. fires the timers that are due, all in simulation time (the first at time
   zero, so reports fall on whole decision steps): HEARTBEAT and
   SYS_STATUS at 1 Hz, the position/attitude messages each autopilot's stream
   schedule has due (:mod:`sim_vehicles.streams`), ``SensorReport`` (and the
   target's ``TargetTruth``) at ``report_rate_hz`` and ``NavReport`` at
   ``nav_rate_hz`` (scenario ``[simulation]``); before a vehicle's report, about
   once a second, the scenario it flies (``VehicleScenario``,
   :class:`~sim_vehicles.zenoh_out.ScenarioAnnouncer`);
3. lets each autopilot run its own loop (:meth:`SimAutopilot.update`), then
   advances the scene under each autopilot's guidance;
4. sleeps until wall time catches up with ``elapsed / rate``.

So ``--rate R`` scales every timer consistently: at R = 10 a vehicle sends ten
heartbeats per wall-clock second and 300 s of flight take 30 s. When the
machine cannot keep up, the runner does not skip steps; it runs late and counts
the steps that started behind schedule (``late_steps`` in the summary). With
``lockstep`` (:mod:`sim_vehicles.lockstep`) it also holds each step while it is
more than one report period ahead of the slowest other vehicle under the
prefix, so that the processes of one run keep one clock (``held_steps``,
``held_s``). With ``wait_for_plans`` (:mod:`sim_vehicles.plan_clock`) it holds
each step until the ground station's plan of the decision step reached has
come, and the wall schedule moves on by the time held (``plan_held_steps``,
``plan_held_s``, ``plan_waits_timed_out``).

Wire stamps are simulation time (``epoch_ns + elapsed``), so a daemon that
orders data by stamp sees the same data at any rate.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path

import zenoh

from gcs.adapters.zenoh_session import has_subscribers, open_session, publish
from gcs.config import Scenario
from gcs.core.world import World
from protocols.errors import ProtocolError
from protocols.keys import alive_key
from sim_vehicles.autopilot import SimAutopilot
from sim_vehicles.personalities import make_autopilot
from sim_vehicles.lockstep import PeerClock, wait_for_vehicles
from sim_vehicles.plan_clock import STALE_AFTER_S as PLAN_STALE_AFTER_S
from sim_vehicles.plan_clock import PlanClock
from sim_vehicles.run_options import RunOptions, RunSummary
from sim_vehicles.mavlink_endpoint import MavlinkEndpoints
from sim_vehicles.scene import Scene
from sim_vehicles.zenoh_out import ScenarioAnnouncer, close_zenoh, declare_vehicle_publishers

__all__ = ["Runner", "DEFAULT_MAVLINK"]

log = logging.getLogger(__name__)

DEFAULT_MAVLINK = "udpout:127.0.0.1:14550"
"""Where every vehicle sends unless told otherwise: one GCS port, demultiplexed by sysid."""
NS_PER_S = 1_000_000_000
HOLD_POLL_S = 0.001
"""How often a held step looks at the other vehicles' reports again (wall seconds)."""


class _Timer:
    """A periodic event in simulation time, free of drift (the n-th firing is due at n / rate_hz)."""

    def __init__(self, rate_hz: float) -> None:
        self.period_s = 1.0 / rate_hz
        self.count = 0

    def due(self, elapsed_s: float) -> bool:
        if elapsed_s + 1e-9 >= self.count * self.period_s:
            self.count = math.floor((elapsed_s + 1e-9) / self.period_s) + 1
            return True
        return False


class Runner:
    """Runs a :class:`Scene` with its vehicles' MAVLink peers and Zenoh publishers.

    ``clock`` and ``sleep`` are the monotonic wall clock (seconds) the run is paced against and its sleep;
    ``unix_ns`` is the Unix time (ns) that ``options.start_at_ns`` is read against (tests give fake ones).
    """

    def __init__(self, scenario: Scenario, world: World, options: RunOptions, base_dir: Path | None = None,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep,
                 unix_ns: Callable[[], int] = time.time_ns) -> None:
        if not options.rate > 0:
            raise ValueError(f"--rate must be > 0, got {options.rate}")
        if options.start_with and options.zenoh is None:
            raise ValueError("start_with hears the other vehicles over zenoh: it needs a zenoh session")
        self.scenario = scenario
        self.options = options
        self.clock, self.sleep, self.unix_ns = clock, sleep, unix_ns
        self.scene = Scene(scenario, world, options.seed, options.epoch_ns, base_dir, options.only)
        self.vehicles = [v for v in scenario.vehicles if v.id in self.scene.vehicles]
        self.publishes_truth = scenario.vehicles[0].id in self.scene.vehicles
        self.summary = RunSummary()
        self.stop_event = threading.Event()
        self.endpoints: MavlinkEndpoints | None = None
        self.autopilots: dict[str, SimAutopilot] = {}
        self.session: zenoh.Session | None = None
        self.publishers: dict[tuple[str, str], zenoh.Publisher] = {}
        self.tokens: list[zenoh.LivelinessToken] = []
        self.peers: PeerClock | None = None
        self.plans: PlanClock | None = None
        self.announcer = ScenarioAnnouncer(scenario)
        self._report_period_ns = round(NS_PER_S / scenario.simulation.report_rate_hz)

    # ------------------------------------------------------------- lifecycle

    def _open(self) -> None:
        sim = self.scenario.simulation
        by_sysid = {v.sysid: v.id for v in self.vehicles}
        if self.options.mavlink is not None:
            connections = {v.sysid: self.options.mavlink[v.id] for v in self.vehicles}
            self.endpoints = MavlinkEndpoints(connections, self.options.signing_key)
            for vehicle in self.vehicles:
                autopilot = make_autopilot(self.scenario.autopilot_for(vehicle), vehicle.sysid, self.scene.frame,
                                           sim.airframe, vehicle.speed_mps, vehicle.altitude_m,
                                           self.endpoints.encoder(vehicle.sysid), sim.telemetry_rate_hz,
                                           on_ground=sim.start_on_ground)
                autopilot.start(self.scene.vehicles[vehicle.id].state)
                self.autopilots[vehicle.id] = autopilot
            log.info("MAVLink: %s", ", ".join(f"{by_sysid[s]} (sysid {s}) -> {c}" for s, c in connections.items()))
        if self.options.zenoh is not None:
            session = self.session = open_session(self.options.zenoh)
            prefix = self.options.prefix
            self.publishers = declare_vehicle_publishers(session, [v.id for v in self.vehicles], prefix,
                                                         [t.id for t in self.scenario.all_targets]
                                                         if self.publishes_truth else ())
            if self.options.lockstep:
                wall_period_s = self._report_period_ns / NS_PER_S / self.options.rate
                self.peers = PeerClock(session, prefix, [v.id for v in self.vehicles], wall_period_s,
                                       self.clock)
            if self.options.wait_for_plans:
                self.plans = PlanClock(session, prefix, [v.id for v in self.vehicles], self._report_period_ns,
                                       self.options.epoch_ns, clock=self.clock)
            log.info("Zenoh: %s session, prefix %r, %d vehicles", self.options.zenoh.mode, prefix, len(self.vehicles))
            self._wait_for_subscriber()

    def _declare_tokens(self) -> None:
        """The vehicles' liveliness tokens: from now on a ground station waits for their reports."""
        if self.session is not None:
            for vehicle in self.vehicles:
                self.tokens.append(self.session.liveliness().declare_token(alive_key(vehicle.id, self.options.prefix)))

    def _wait_for_subscriber(self) -> None:
        # the scenario announcement is not waited for: a ground station that does not know it never subscribes
        publishers = [p for (_, kind), p in self.publishers.items() if kind != "scenario"]
        if not publishers or self.options.wait_for_subscriber_s <= 0:
            return
        deadline = self.clock() + self.options.wait_for_subscriber_s
        while publishers and not all(has_subscribers(p) for p in publishers):
            if self.clock() >= deadline or self.stop_event.is_set():
                log.info("not every key has a subscriber yet; flying anyway")
                return
            self.stop_event.wait(0.02)
        log.info("every key has a subscriber")

    def close(self) -> None:
        """Withdraw liveliness, close the Zenoh session and the MAVLink sockets."""
        if self.peers is not None:
            self.peers.close()
            self.peers = None
        if self.plans is not None:
            self.plans.close()
            self.plans = None
        close_zenoh(self.tokens, self.publishers, self.session)
        self.tokens.clear()
        self.session = None
        if self.endpoints is not None:
            self.summary.mavlink.update(self.endpoints.counters())
            self.endpoints.close()
            self.endpoints = None

    def stop(self) -> None:
        """Ask the loop to finish (thread-safe; signal handlers call it)."""
        self.stop_event.set()

    # ------------------------------------------------------------------ loop

    def run(self) -> RunSummary:
        """Run until the duration is flown or :meth:`stop` is called; always closes what it opened."""
        try:
            self._open()
            self._loop()
        finally:
            self.close()
        return self.summary

    def _loop(self) -> None:
        sim = self.scenario.simulation
        dt = sim.physics_step_s
        scene = self.scene
        heartbeat = _Timer(1.0)
        reports, navs = _Timer(sim.report_rate_hz), _Timer(sim.nav_rate_hz)
        progress = _Timer(1.0 / 30.0)
        skipped = 0
        start_at_ns = self.options.start_at_ns
        ahead_s = None if start_at_ns is None else (start_at_ns - self.unix_ns()) / 1e9
        if start_at_ns is not None and ahead_s is not None and ahead_s <= 0:  # the clock started: join it now
            skipped = self._join(dt, (heartbeat, reports, navs, progress), start_at_ns)
            wall_start = self.clock() - (self.unix_ns() - start_at_ns) / 1e9
            self._declare_tokens()
        else:
            self._declare_tokens()
            if self.options.start_with:
                self._wait_for_fleet()
            elif ahead_s is not None:
                self.stop_event.wait(ahead_s)
            wall_start = self.clock()
        steps_total = None if self.options.duration_s is None else round(self.options.duration_s / dt) - skipped
        while not self.stop_event.is_set() and (steps_total is None or self.summary.steps < steps_total):
            if self.peers is not None:
                self._keep_step()
            if self.plans is not None:
                wall_start += self._wait_for_plan()  # the wait stops the clock: the run goes on at its rate
            self._receive()
            now = scene.elapsed_s
            if heartbeat.due(now):
                self._send_all(lambda vid, ap: [ap.heartbeat(), ap.sys_status()])
            self._send_all(lambda vid, ap: ap.streams(now, scene.vehicles[vid].state, scene.vehicles[vid].gps,
                                                      scene.wind))
            if reports.due(now):
                for vehicle_id in scene.vehicles:
                    report = scene.sensor_report(vehicle_id)
                    announcement = self.announcer.due(vehicle_id, report.stamp_ns)
                    if announcement is not None:
                        self._publish(vehicle_id, "scenario", announcement)
                    self.summary.reports[vehicle_id] += 1
                    self.summary.detections[vehicle_id] += report.detected
                    self._publish(vehicle_id, "report", report)
                for truth in scene.truths():
                    self._publish(truth.target_id, "truth", truth)
            if navs.due(now):
                for vehicle_id in scene.vehicles:
                    self.summary.nav_reports[vehicle_id] += 1
                    self._publish(vehicle_id, "nav", scene.nav_report(vehicle_id))
            if progress.due(now):
                log.info("t = %.0f s: %s", now, ", ".join(
                    f"{vid} {self.autopilots[vid].mode_name if vid in self.autopilots else 'loiter'} "
                    f"{self.summary.detections[vid]}/{self.summary.reports[vid]} seen" for vid in scene.vehicles))
            for vid, ap in self.autopilots.items():
                ap.update(now, scene.vehicles[vid].state, scene.wind)
            guidance = {vid: ap.guidance for vid, ap in self.autopilots.items() if ap.guidance is not None}
            scene.advance(dt, guidance)
            self.summary.steps += 1
            lag = wall_start + scene.elapsed_s / self.options.rate - self.clock()
            if lag > 0:
                self.sleep(lag)  # at most one physics step of wall time: stop() is seen promptly
            elif lag < -dt / self.options.rate:
                self.summary.late_steps += 1
        self.summary.simulated_s = scene.elapsed_s
        self.summary.wall_s = self.clock() - wall_start
        self.summary.modes = {vid: (self.autopilots[vid].mode_name if vid in self.autopilots else "LOITER")
                              for vid in scene.vehicles}

    def _join(self, dt: float, timers: tuple[_Timer, ...], start_at_ns: int) -> int:
        """Join a run whose clock started before now (``start_at_ns`` in the past, e.g. a vehicle process
        restarted after a crash): move the target, publishing nothing, to the shared clock's time (with
        lockstep, to the median of the others' newest reports when some are heard), taking the time the move
        itself takes into account, so that it is where the other processes have it; the timers then fire from
        the next period. Returns the physics steps skipped."""
        dt_ns = round(dt * NS_PER_S)
        if self.peers is not None:
            self._wait_for_peers()

        def goal_ns() -> int:
            """The shared clock's time now; with lockstep and other vehicles heard, one physics step past
            the median of their newest reports, so that the first report is for a step that the vehicles at
            or behind the median have not reported for yet (still open at a ground station); lockstep then
            holds it until the slowest is within a report."""
            middle = self.peers.middle_ns() if self.peers is not None else None
            if middle is not None:
                return middle - self.scene.epoch_ns + dt_ns
            return round((self.unix_ns() - start_at_ns) * self.options.rate)

        steps = 0
        while self.scene.elapsed_ns + dt_ns <= (goal := goal_ns()):
            for _ in range(100):  # the goal moves on while the target is moved: look again every 100 steps
                if self.stop_event.is_set():
                    return steps
                if self.scene.elapsed_ns + dt_ns > goal:
                    break
                self.scene.skip_target(dt)
                steps += 1
            if self.peers is not None:
                self.peers.poll()
        elapsed = self.scene.elapsed_s
        for timer in timers:
            timer.count = math.ceil(elapsed / timer.period_s - 1e-9)
        for autopilot in self.autopilots.values():
            autopilot.schedule.skip_to(elapsed)
        log.info("joined the run at t = %.1f s (the target moved %d steps without publishing)", elapsed, steps)
        return steps

    def _wait_for_fleet(self) -> None:
        """``start_with``: hold the clock at zero until each of those vehicles has its liveliness token up (or the
        run is stopped)."""
        others = self.options.start_with
        if self.session is None:  # (start_with needs zenoh: RunOptions says so)
            return
        if not wait_for_vehicles(self.session, self.options.prefix, others, lambda: not self.stop_event.is_set(),
                                 self.clock):
            log.info("%s up: the clock starts", ", ".join(others))

    def _wait_for_peers(self) -> None:
        """Before joining: up to two report periods (at least 0.5 s) of wall time for the report of every
        other vehicle whose token is up."""
        peers = self.peers
        if peers is None:
            return
        deadline = self.clock() + max(0.5, 2.0 * self._report_period_ns / NS_PER_S / self.options.rate)
        while self.clock() < deadline and not self.stop_event.is_set():
            peers.poll()
            if peers.alive and peers.alive <= peers.newest_ns.keys():
                return
            self.stop_event.wait(0.01)

    def _keep_step(self) -> None:
        """Lockstep: hold this step while the scene is more than one report period ahead of the slowest other
        vehicle (see :mod:`sim_vehicles.lockstep`)."""
        peers, stamp = self.peers, self.scene.stamp_ns
        if peers is None:
            return
        peers.poll()
        if not peers.ahead(stamp, self._report_period_ns):
            return
        self.summary.held_steps += 1
        start = self.clock()
        while not self.stop_event.wait(HOLD_POLL_S):
            peers.poll()
            if not peers.ahead(stamp, self._report_period_ns):
                break
        self.summary.held_s += self.clock() - start

    def _wait_for_plan(self) -> float:
        """Hold this step until the ground station's plan of the decision step reached has come, for at most
        :data:`~sim_vehicles.plan_clock.STALE_AFTER_S` of wall time (see :mod:`sim_vehicles.plan_clock`); the
        wall seconds held."""
        stamp, plans = self.scene.stamp_ns, self.plans
        if plans is None or not plans.behind(stamp):
            return 0.0
        self.summary.plan_held_steps += 1
        start = self.clock()
        while not self.stop_event.wait(HOLD_POLL_S):
            if not plans.behind(stamp):
                break
            if self.clock() - start >= PLAN_STALE_AFTER_S:
                self.summary.plan_waits_timed_out += 1
                break
        held = self.clock() - start
        self.summary.plan_held_s += held
        return held

    def _receive(self) -> None:
        if self.endpoints is None:
            return
        by_sysid = {ap.sysid: (vid, ap) for vid, ap in self.autopilots.items()}
        for sysid, message in self.endpoints.receive():
            vehicle_id, autopilot = by_sysid[sysid]
            for reply in autopilot.handle(message, self.scene.elapsed_s, self.scene.vehicles[vehicle_id].state):
                self.endpoints.send(sysid, reply)

    def _send_all(self, build) -> None:
        if self.endpoints is None:
            return
        for vehicle_id, autopilot in self.autopilots.items():
            for message in build(vehicle_id, autopilot):
                self.endpoints.send(autopilot.sysid, message)

    def _publish(self, vehicle_id: str, kind: str, message) -> None:
        publisher = self.publishers.get((vehicle_id, kind))
        if publisher is None:
            return
        try:
            publish(publisher, message)
        except ProtocolError as error:  # a bug in a truth model must not stop the vehicles
            self.summary.unpublishable[kind] += 1
            log.error("%s %s not published: %s", vehicle_id, kind, error)
