"""Flights of the ground station with real ArduPlanes (ArduPilot SITL), flown as a user flies them, and measured.

In a private network namespace (:mod:`benchmarks.sitl.namespace`; this module refuses to run outside one):

1. one ArduPlane SITL per scenario vehicle (instance ``i``, the vehicle's sysid, home at its start
   position and heading, at the origin's height), on the ground and disarmed; a pilot
   (:class:`~benchmarks.sitl.pilot.Pilot`) on each SERIAL0, which starts SITL's simulation, reads the
   modes it reports and SITL's clock;
2. airborne, one of two ways (``takeoff``): ``daemon``, as ``gcs run --takeoff`` does it (the daemon
   arms each vehicle and puts it in TAKEOFF once it has a plan for it, then takes it over), the target
   starting at once; or ``pilot``, as a pilot does before handing the vehicles to the ground station:
   the pilots arm, take off and fly each vehicle to its scenario start point and altitude
   (DO_REPOSITION), and the target starts once all are there;
3. for each seed: the daemon, in this process, with ``gcs run``'s options (``--takeoff``, each vehicle
   on its SITL's SERIAL2, ``--vehicle ID=tcp:...``, through a :class:`~benchmarks.sitl.relay.TcpRelay`
   for a vehicle whose link is cut; its Zenoh peer on a loopback port the system chooses; no live map),
   and the payload bridge (``sim-vehicles payload`` on each SERIAL1, a process of its own) for
   ``duration_s``: the target starts when the bridge does. Then the daemon is stopped as Ctrl-C stops it
   (it hands the vehicles back) and the pilots wait for the hand-back mode. With ``pilot`` the vehicles
   are flown back to their start points before the next seed.

Measured per seed (:func:`_report`): when each vehicle was taken over; the telemetry rates the daemon
received; its MAVLink counters per vehicle; the course following
(:func:`benchmarks.course_following.course_following` on the daemon's own telemetry at each steering
instant, from :data:`SETTLE_S` after the first plan, with the lead the daemon asked for and the bank
the plane flew then); the decision steps scored against the bridge's
truth (:func:`gcs.daemon.demo_summary.summarise`); SITL's clock against the wall clock over the flight;
each vehicle's mode changes as SITL reports them; and for ``cut``, when the daemon lost and found the
link again.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.course_following import SteeringSample, course_following
from benchmarks.sitl.arduplane import ArduPlaneSitl, defaults_beside, find_binary
from benchmarks.sitl.namespace import in_private_network
from benchmarks.sitl.pilot import Pilot
from benchmarks.sitl.relay import TcpRelay
from gcs.adapters.mavlink_wire import mavlink
from gcs.config import Scenario
from gcs.core.geometry import LocalFrame, wrap_angle
from gcs.daemon.app import Daemon
from gcs.daemon.cli import add_run, build_daemon
from gcs.daemon.demo_summary import summarise
from gcs.scenarios import load_scenario

__all__ = ["FlightOptions", "TAKEOFFS", "fly", "main"]

log = logging.getLogger(__name__)

TAKEOFFS = ("daemon", "pilot")
SETTLE_S = 10.0
"""Course following is counted from this long after the first plan (as in :func:`benchmarks.autopilots.fly`)."""
OBSERVED_RATE_HZ = 10.0
PILOT_TAKEOFF_M = 40.0
POSITION_TIMEOUT_S = 240.0
NEAR_START_M, NEAR_ALTITUDE_M = 400.0, 20.0
HANDBACK_WAIT_S = 15.0
STREAMS = ("GLOBAL_POSITION_INT", "ATTITUDE")


@dataclass(frozen=True)
class FlightOptions:
    """What to fly (module docstring); ``cut``: a vehicle, when (s after the target starts) and for how long."""

    sitl: Path
    scenario: str = "wang2012_urban"
    seeds: tuple[int, ...] = (0,)
    duration_s: float = 300.0
    takeoff: str = "daemon"
    cut: tuple[str, float, float] | None = None
    handback_after_s: float = 60.0
    speedup: float = 1.0


@dataclass
class _Vehicle:
    """One vehicle's SITL, pilot and optional relay."""

    sitl: ArduPlaneSitl
    pilot: Pilot
    relay: TcpRelay | None = None


def _home(scenario: Scenario, frame: LocalFrame, index: int) -> tuple[float, float, float, float]:
    vehicle = scenario.vehicles[index]
    lat, lon, _ = frame.to_geodetic([vehicle.start_enu_m[0], vehicle.start_enu_m[1], 0.0])
    heading_ned_deg = math.degrees(math.pi / 2 - vehicle.start_heading_rad) % 360.0
    return float(lat), float(lon), frame.height_m, heading_ned_deg


def _daemon(options: FlightOptions, seed: int, connections: dict[str, str]) -> Daemon:
    """The daemon ``gcs run`` builds from these options."""
    parser = argparse.ArgumentParser()
    add_run(parser.add_subparsers())
    argv = ["run", "--scenario", options.scenario, "--seed", str(seed), "--takeoff", "--http", "none",
            "--handback-after", str(options.handback_after_s), "--zenoh-mode", "peer",
            "--zenoh-listen", "tcp/127.0.0.1:0"]
    for vehicle_id, connection in connections.items():
        argv += ["--vehicle", f"{vehicle_id}={connection}"]
    return build_daemon(parser.parse_args(argv))


def _start_pilots(vehicles: dict[str, _Vehicle]) -> None:
    """Wait for each autopilot and ask for its telemetry at :data:`OBSERVED_RATE_HZ` on the pilot's port."""
    for vehicle in vehicles.values():
        pilot = vehicle.pilot
        pilot.wait_for("a heartbeat", lambda p=pilot: "HEARTBEAT" in p.latest, 60.0)
        for name in STREAMS:
            pilot.request_rate(getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), OBSERVED_RATE_HZ)


def _fly_to_starts(vehicles: dict[str, _Vehicle], scenario: Scenario, frame: LocalFrame) -> None:
    """Send each vehicle to its start point and altitude (every 10 s) until all are near them."""
    deadline = time.monotonic() + POSITION_TIMEOUT_S
    next_send = 0.0
    while True:
        near = True
        for config in scenario.vehicles:
            pilot = vehicles[config.id].pilot
            pilot.pump()
            position = pilot.latest.get("GLOBAL_POSITION_INT")
            if position is None:
                near = False
                continue
            enu = frame.to_enu(position.lat * 1e-7, position.lon * 1e-7, frame.height_m)
            distance = math.hypot(enu[0] - config.start_enu_m[0], enu[1] - config.start_enu_m[1])
            near &= distance < NEAR_START_M and abs(pilot.altitude_m - config.altitude_m) < NEAR_ALTITUDE_M
        if near:
            return
        if time.monotonic() > deadline:
            raise RuntimeError(f"the vehicles did not reach their start points within {POSITION_TIMEOUT_S:g} s")
        if time.monotonic() >= next_send:
            next_send = time.monotonic() + 10.0
            for config in scenario.vehicles:
                lat, lon, _ = frame.to_geodetic([config.start_enu_m[0], config.start_enu_m[1], 0.0])
                vehicles[config.id].pilot.reposition(float(lat), float(lon), config.altitude_m)
        time.sleep(0.05)


class _Flight:
    """One seed's flight, run from the daemon's loop (:meth:`until` is called on every pass)."""

    def __init__(self, options: FlightOptions, seed: int, daemon: Daemon, vehicles: dict[str, _Vehicle]) -> None:
        self.options, self.seed, self.daemon, self.vehicles = options, seed, daemon, vehicles
        self.started = time.monotonic()
        self.bridge: subprocess.Popen | None = None
        self.first_plan: float | None = None
        self.clock: list[tuple[float, float]] = []
        self.cut_events: dict[str, float] = {}
        self.counters_at_restore: dict[str, int] | None = None
        self.samples: dict[str, list[SteeringSample]] = {vid: [] for vid in vehicles}
        self.modes: dict[str, list[tuple[float, str]]] = {vid: [] for vid in vehicles}
        self.guided_s: dict[str, float | None] = {vid: None for vid in vehicles}
        self.commands: dict[str, list[tuple[float, float | None, float | None]]] = {vid: [] for vid in vehicles}

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def start_bridge(self) -> None:
        """The payload bridge for this seed: the target starts now."""
        (endpoint,) = self.daemon.zenoh_listening
        command = [sys.executable, "-m", "sim_vehicles.cli", "--log-level", "WARNING", "payload", "--scenario",
                   self.options.scenario, "--seed", str(self.seed), "--duration", str(self.options.duration_s),
                   "--request-rate", "5", "--zenoh-connect", endpoint]
        for vehicle_id, vehicle in self.vehicles.items():
            command += ["--vehicle", f"{vehicle_id}={vehicle.sitl.connection(1)}"]
        self.started = time.monotonic()
        self.bridge = subprocess.Popen(command, stdin=subprocess.DEVNULL)
        self._tick_clock()

    def _tick_clock(self) -> None:
        pilot = next(iter(self.vehicles.values())).pilot
        if "GLOBAL_POSITION_INT" in pilot.latest:
            self.clock.append((time.monotonic(), pilot.boot_s))

    def observe(self) -> None:
        """Read the pilots: the modes as SITL reports them."""
        now = self.elapsed()
        for vehicle_id, vehicle in self.vehicles.items():
            vehicle.pilot.pump()
            mode, modes = vehicle.pilot.mode, self.modes[vehicle_id]
            if mode is not None and (not modes or modes[-1][1] != mode):
                modes.append((now, mode))
                if mode == "GUIDED" and self.guided_s[vehicle_id] is None and self.daemon.commander is not None \
                        and self.daemon.commander.link(vehicle_id).counters["mode_requests"]:
                    self.guided_s[vehicle_id] = now

    def until(self) -> bool:
        """One pass of the schedule; True once the bridge has ended."""
        self.observe()
        if self.first_plan is None and self.daemon.plans:
            self.first_plan = self.elapsed()
        self._cut(self.elapsed())
        if len(self.clock) < 1:
            self._tick_clock()
        if self.bridge is not None and self.bridge.poll() is not None:
            self._tick_clock()
            return True
        return False

    def _cut(self, now: float) -> None:
        if self.options.cut is None or self.daemon.commander is None:
            return
        vehicle_id, at_s, for_s = self.options.cut
        relay = self.vehicles[vehicle_id].relay
        assert relay is not None
        link = self.daemon.commander.link(vehicle_id)
        events = self.cut_events
        if "cut_s" not in events and now >= at_s:
            relay.cut()
            events["cut_s"] = now
        elif "cut_s" in events and "restored_s" not in events and now >= at_s + for_s:
            relay.restore()
            events["restored_s"] = now
            self.counters_at_restore = dict(link.counters)
        if "cut_s" in events and "lost_s" not in events and not link.alive(
                self.daemon.clock(), self.daemon.commander.link_timeout_s):
            events["lost_s"] = now
        if "restored_s" in events and "up_again_s" not in events and link.alive(self.daemon.clock(), 1.5):
            events["up_again_s"] = now

    def steered(self, now: float, steered) -> None:
        """The daemon's steering pass: a course-following sample per vehicle (after :data:`SETTLE_S`)."""
        if self.first_plan is None or self.elapsed() - self.first_plan < SETTLE_S or self.daemon.commander is None:
            return
        for vehicle_id, path in steered:
            link = self.daemon.commander.link(vehicle_id)
            course = link.course_rad()
            if link.position_enu_m is None or course is None or link.position_stamp_s is None:
                continue
            index = path.nearest(link.position_enu_m)
            self.samples[vehicle_id].append(SteeringSample(
                link.position_stamp_s, course, wrap_angle(course - float(path.courses[index])),
                float(path.turn_rates[index])))
            attitude = self.vehicles[vehicle_id].pilot.latest.get("ATTITUDE")
            lead = None if link.command is None else wrap_angle(link.command.heading_enu_rad - course)
            self.commands[vehicle_id].append((link.position_stamp_s, lead, getattr(attitude, "roll", None)))


def _fly_seed(options: FlightOptions, seed: int, scenario: Scenario, vehicles: dict[str, _Vehicle]) -> dict:
    connections = {vid: f"tcp:127.0.0.1:{v.relay.port}" if v.relay is not None else v.sitl.connection(2)
                   for vid, v in vehicles.items()}
    daemon = _daemon(options, seed, connections)
    flight = _Flight(options, seed, daemon, vehicles)
    daemon.on_steered = flight.steered
    try:
        daemon.open()
        flight.start_bridge()
        daemon.run(until=flight.until)  # closes the daemon: the vehicles are handed back
    finally:
        daemon.close()
        if flight.bridge is not None and flight.bridge.poll() is None:
            flight.bridge.terminate()
            flight.bridge.wait(timeout=10)
        if options.cut is not None:
            relay = vehicles[options.cut[0]].relay
            assert relay is not None
            relay.restore()
    stopped = flight.elapsed()
    deadline = time.monotonic() + HANDBACK_WAIT_S
    while time.monotonic() < deadline and not all(v.pilot.mode == daemon.options.takeover.handback
                                                  for v in vehicles.values()):
        flight.observe()
        time.sleep(0.05)
    flight.observe()
    return _report(options, scenario, daemon, flight, stopped)


def fly(options: FlightOptions) -> list[dict]:
    """The flights of every seed (module docstring): the measured figures of each."""
    if not in_private_network():
        raise RuntimeError("ArduPlane SITL runs only in a network namespace of its own "
                           "(benchmarks.sitl.namespace.namespace_command)")
    if options.takeoff not in TAKEOFFS:
        raise ValueError(f"takeoff {options.takeoff!r}; expected one of {', '.join(TAKEOFFS)}")
    scenario = load_scenario(options.scenario)
    frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
    binary = find_binary(options.sitl)
    vehicles: dict[str, _Vehicle] = {}
    try:
        for index, config in enumerate(scenario.vehicles):
            sitl = ArduPlaneSitl(binary, index, config.sysid, _home(scenario, frame, index), speedup=options.speedup,
                                 defaults=defaults_beside(binary)).start()
            relay = None
            if options.cut is not None and options.cut[0] == config.id:
                relay = TcpRelay(("127.0.0.1", sitl.port(2)))
            vehicles[config.id] = _Vehicle(sitl, Pilot(sitl.connection(0), config.sysid), relay)
        _start_pilots(vehicles)
        if options.takeoff == "pilot":
            for vehicle in vehicles.values():
                vehicle.pilot.take_off(PILOT_TAKEOFF_M)
        reports = []
        for seed in options.seeds:
            if options.takeoff == "pilot":
                _fly_to_starts(vehicles, scenario, frame)
            reports.append(_fly_seed(options, seed, scenario, vehicles))
            log.info("seed %d flown: %s", seed, reports[-1]["summary"])
        return reports
    finally:
        for vehicle in vehicles.values():
            vehicle.pilot.close()
            if vehicle.relay is not None:
                vehicle.relay.close()
            vehicle.sitl.stop()


def _report(options: FlightOptions, scenario: Scenario, daemon: Daemon, flight: _Flight, stopped_s: float) -> dict:
    """The figures of one seed's flight (module docstring)."""
    assert daemon.commander is not None
    ids = list(flight.vehicles)
    limit = float(min(daemon.engine.tracker.max_turn_rate))  # the planner's: what the autopilot reaches
    clock = None
    if len(flight.clock) >= 2:
        (wall0, sitl0), (wall1, sitl1) = flight.clock[0], flight.clock[-1]
        clock = {"wall_s": wall1 - wall0, "sitl_s": sitl1 - sitl0, "ratio": (sitl1 - sitl0) / (wall1 - wall0)}
    flown = stopped_s
    return {
        "scenario": scenario.name, "seed": flight.seed, "duration_s": options.duration_s, "vehicles": ids,
        "takeoff": options.takeoff, "takeover_s": flight.guided_s, "daemon_stopped_s": stopped_s,
        "modes": flight.modes,
        "streams_hz": {vid: {name: daemon.commander.link(vid).arrivals[name] / flown for name in STREAMS}
                       for vid in ids},
        "mavlink": {vid: dict(daemon.commander.link(vid).counters) for vid in ids},
        "mavlink_at_restore": flight.counters_at_restore,
        "connects": {vid: getattr(daemon.commander.connection(vid), "connects", None) for vid in ids},
        "cut": flight.cut_events,
        "course_following": course_following(list(flight.samples.values()), limit),
        "samples": {vid: [[s.time_s, s.course_rad, s.course_error_rad, s.planned_rate_rad_s] for s in samples]
                    for vid, samples in flight.samples.items()},
        "commands": flight.commands,
        "max_turn_rate_rad_s": limit,
        "clock": clock,
        "summary": summarise(daemon.records, daemon.plans, daemon.roster),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sitl.flight", description=__doc__.splitlines()[0])
    parser.add_argument("--sitl", type=Path, required=True)
    parser.add_argument("--scenario", default="wang2012_urban")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--duration", type=float, default=300.0)
    parser.add_argument("--takeoff", choices=TAKEOFFS, default="daemon")
    parser.add_argument("--cut", nargs=3, metavar=("VEHICLE", "AT_S", "FOR_S"))
    parser.add_argument("--handback-after", type=float, default=60.0)
    parser.add_argument("--speedup", type=float, default=1.0)
    parser.add_argument("--json", type=Path, required=True)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    cut = None if args.cut is None else (args.cut[0], float(args.cut[1]), float(args.cut[2]))
    reports = fly(FlightOptions(args.sitl, args.scenario, tuple(args.seeds), args.duration, args.takeoff, cut,
                                args.handback_after, args.speedup))
    args.json.write_text(json.dumps(reports))
    return 0


if __name__ == "__main__":
    sys.exit(main())
