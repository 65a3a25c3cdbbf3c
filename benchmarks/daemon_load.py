"""The load of ``gcs-bench daemon``: N vehicles' reports over Zenoh from a process of their own.

:func:`publisher_main` runs in a spawned process. It listens on a loopback
endpoint (the daemons under test connect to it, one after the other), declares
a liveliness token and report and nav publishers (reliable, ``BLOCK``) per
vehicle, and obeys commands from a pipe:

* ``warmup``: once the daemon's subscribers match, one ``NavReport`` per
  vehicle (heading and velocity: the vehicle becomes plannable) and one round
  of reports;
* ``prepare(rate, seconds, burst)``, then ``run``: whole rounds at an aggregate
  rate, all encoded by ``prepare`` so that ``run`` only paces and puts. Round k
  carries one ``SensorReport`` per vehicle stamped ``T_0 + k * step``: one
  decision step of data time per round, every (vehicle, stamp) unique. With
  ``Fleet.nav_per_round`` each vehicle's report is preceded by a ``NavReport``
  of the same stamp with a 3D GPS fix where the vehicle is (the daemon's own
  navigation then has what it waits for; not counted in the rate). The
  reply holds each round's stamp and the wall time (``time.time_ns``) read just
  before its last report was put, and the process's CPU time;
* ``stop``.

The process runs :data:`LOAD_NICENESS` below the priority it was started with
(the daemon's): it stands in for vehicles that fly their own computers.

Every report is a range/azimuth/elevation detection, without noise, of a target
standing where the scenario's target starts, by a vehicle where the scenario
(:func:`benchmarks.urban.with_vehicles` for more of them) starts it. Like the
simulated vehicles' (and a real one's), each report states its position's 1-sigma,
:data:`REPORTED_POSITION_STD_M`, which the daemon fuses as the vehicle's uncertainty.
"""

from __future__ import annotations

import math
import signal
import time
from dataclasses import dataclass

import numpy as np

from gcs.adapters.zenoh_session import ZenohSettings, declare_publisher, listening_endpoints, open_session
from gcs.config import Scenario
from gcs.core.geometry import LocalFrame
from gcs.daemon.niceness import lower_priority
from protocols.codec import encode
from protocols.keys import alive_key, nav_key, report_key
from protocols.messages import GpsFix, Measurement, NavReport, SensorReport

__all__ = ["FIRST_STAMP_NS", "LOAD_NICENESS", "Vehicle", "Fleet", "Load", "publisher_main"]

NS_PER_S = 1_000_000_000
FIRST_STAMP_NS = 1_000 * NS_PER_S
"""Stamp of the first round (any positive time: stamps are data time)."""
REPORTED_POSITION_STD_M = 2.0
"""The 1-sigma each report states for its vehicle's position (m per axis; the GPS fix's ``h_acc_m``)."""
LOAD_NICENESS = 5
"""How much lower the load process's scheduling priority is than the benchmark's (the daemon's), by default.

In use the vehicles report from their own computers; here they share the daemon's
CPUs. At the same priority, on 2 cores, the scheduler's sharing between the two
showed in the daemon's tail: at 10 vehicles and 5,000 reports/s the report-to-command
p99 was over 20 ms in 4 of 15 trials (up to 147 ms), with the load 5 lower in none
(at most 18.1 ms; docs/benchmarks.md). The planner process runs 5 lower too. The
load must still achieve each trial's rate, or the trial fails, and each round's send
time is read before its last report is put, so a load preempted around its put can
only lengthen the latency measured."""


@dataclass(frozen=True)
class Vehicle:
    """What the load needs of one vehicle: id, position (ENU, m), heading, speed, its detection of the target."""

    id: str
    position_enu_m: tuple[float, float, float]
    heading_rad: float
    speed_mps: float
    range_m: float
    azimuth_rad: float
    elevation_rad: float
    lat_lon_alt: tuple[float, float, float]  # where it is, geodetic (deg, deg, m): its GPS fix


@dataclass(frozen=True)
class Fleet:
    """The load's vehicles, sensor noise, decision step and key prefix (picklable, for the spawned process)."""

    vehicles: tuple[Vehicle, ...]
    std: tuple[float, float, float]
    step_ns: int
    prefix: str = "gcs"
    nav_per_round: bool = False

    @classmethod
    def of(cls, scenario: Scenario, prefix: str = "gcs", nav_per_round: bool = False) -> Fleet:
        """Every vehicle of the scenario where it starts, seeing the target where it starts (on the ground)."""
        frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        tx, ty = scenario.target.start_enu_m
        vehicles = []
        for v in scenario.vehicles:
            (x, y), z = (float(c) for c in v.start_enu_m), float(v.altitude_m)  # plain floats for msgspec
            dx, dy, dz = tx - x, ty - y, -z
            lat, lon, height = (float(c) for c in frame.to_geodetic(np.array([x, y, z])))
            vehicles.append(Vehicle(v.id, (x, y, z), float(v.start_heading_rad), float(v.speed_mps),
                                    math.sqrt(dx * dx + dy * dy + dz * dz), math.atan2(dy, dx),
                                    math.atan2(dz, math.hypot(dx, dy)), (lat, lon, height)))
        sensor = scenario.sensor_for(scenario.vehicles[0])
        std = (sensor.range_std_m, sensor.azimuth_std_rad, sensor.elevation_std_rad)
        return cls(tuple(vehicles), std, round(scenario.time.step_s * NS_PER_S), prefix, nav_per_round)


class Load:
    """The publishing side: liveliness tokens, nav reports and paced rounds of sensor reports."""

    def __init__(self, session, fleet: Fleet) -> None:
        self.fleet = fleet
        self.session = session
        prefix = fleet.prefix
        self.reports = [declare_publisher(session, report_key(v.id, prefix), SensorReport) for v in fleet.vehicles]
        self.navs = [declare_publisher(session, nav_key(v.id, prefix), NavReport) for v in fleet.vehicles]
        self.tokens = [session.liveliness().declare_token(alive_key(v.id, prefix)) for v in fleet.vehicles]
        self.next_round = 0
        self.seq = 0
        self._prepared: tuple | None = None

    def close(self) -> None:
        """Withdraw the tokens and the publishers."""
        for entity in self.tokens + self.reports + self.navs:
            entity.undeclare()

    def _stamp(self) -> int:
        stamp = FIRST_STAMP_NS + self.next_round * self.fleet.step_ns
        self.next_round += 1
        return stamp

    def _report(self, slot: int, stamp_ns: int) -> bytes:
        """The encoded ``SensorReport`` of vehicle ``slot`` for ``stamp_ns``."""
        v, (r_std, a_std, e_std) = self.fleet.vehicles[slot], self.fleet.std
        self.seq += 1
        payload, _ = encode(SensorReport(
            vehicle_id=v.id, seq=self.seq, stamp_ns=stamp_ns, vehicle_position_enu_m=v.position_enu_m,
            vehicle_position_std_m=REPORTED_POSITION_STD_M,
            detections=(Measurement(range_m=v.range_m, azimuth_rad=v.azimuth_rad, elevation_rad=v.elevation_rad,
                                    range_std_m=r_std, azimuth_std_rad=a_std, elevation_std_rad=e_std),)))
        return payload

    def _nav(self, slot: int, stamp_ns: int) -> bytes:
        """The encoded ``NavReport`` of vehicle ``slot``: heading and velocity (the vehicle becomes
        plannable), with a GPS fix when ``nav_per_round``."""
        v = self.fleet.vehicles[slot]
        self.seq += 1
        velocity = (v.speed_mps * math.cos(v.heading_rad), v.speed_mps * math.sin(v.heading_rad), 0.0)
        gps = None
        if self.fleet.nav_per_round:
            lat, lon, alt = v.lat_lon_alt
            gps = GpsFix(lat_deg=lat, lon_deg=lon, alt_m=alt, fix_type=3, h_acc_m=REPORTED_POSITION_STD_M,
                         v_acc_m=3.0)
        payload, _ = encode(NavReport(vehicle_id=v.id, seq=self.seq, stamp_ns=stamp_ns, gps=gps,
                                      velocity_enu_mps=velocity, heading_rad=v.heading_rad))
        return payload

    def warmup(self, timeout_s: float = 5.0) -> dict:
        """Once the daemon's subscribers match: a nav report and one round of reports per vehicle."""
        deadline = time.monotonic() + timeout_s
        while not all(p.matching_status.matching for p in self.reports + self.navs) and time.monotonic() < deadline:
            time.sleep(0.01)
        stamp = self._stamp()
        for slot in range(len(self.fleet.vehicles)):
            self.navs[slot].put(self._nav(slot, stamp))
        for slot in range(len(self.fleet.vehicles)):
            self.reports[slot].put(self._report(slot, stamp))
        return {"stamp_ns": stamp}

    def prepare(self, rate: float, seconds: float, burst: bool = False) -> dict:
        """Encode the whole rounds of the next :meth:`run`: ``rate`` reports/s for about ``seconds``.

        Done before the run (and outside the benchmark's timing of it), so that the
        pacing loop only puts: the load's own work competes for the CPUs with the
        daemon it measures.
        """
        count = len(self.fleet.vehicles)
        rounds = max(1, round(rate * seconds / count))
        stamps = [self._stamp() for _ in range(rounds)]
        nav_per_round = self.fleet.nav_per_round
        payloads = [[(self._nav(slot, stamp) if nav_per_round else b"", self._report(slot, stamp))
                     for slot in range(count)] for stamp in stamps]
        self._prepared = (rate, burst, stamps, payloads)
        return {"rounds": rounds}

    def run(self) -> dict:
        """Send what :meth:`prepare` encoded; the send time of each round's last report.

        Reports are evenly spaced, or with ``burst`` a round's reports all go at
        the round's start (as vehicles reporting at the same data time would).
        """
        if self._prepared is None:
            raise RuntimeError("run without prepare")
        (rate, burst, stamps, payloads), self._prepared = self._prepared, None
        count = len(self.fleet.vehicles)
        rounds = len(stamps)
        interval = 1.0 / rate
        nav_per_round = self.fleet.nav_per_round
        last_sent_ns = []
        start, cpu = time.perf_counter(), time.process_time()
        for k, round_ in enumerate(payloads):
            for slot, (nav, report) in enumerate(round_):
                ahead = start + (k * count + (0 if burst else slot)) * interval - time.perf_counter()
                if ahead > 0:
                    time.sleep(ahead)
                if nav_per_round:
                    self.navs[slot].put(nav)
                if slot == count - 1:  # read before the put: the daemon may get the CPU as soon as it is sent
                    last_sent_ns.append(time.time_ns())
                self.reports[slot].put(report)
        elapsed = time.perf_counter() - start
        return {"published": rounds * count, "elapsed_s": elapsed, "stamps": stamps, "last_sent_ns": last_sent_ns,
                "cpu_s": time.process_time() - cpu}


def publisher_main(conn, endpoint: str, fleet: Fleet, niceness: int = LOAD_NICENESS) -> None:
    """The load process: listen on ``endpoint`` (a port of 0: the one the system chooses, sent back in the
    ready message's ``endpoint``) and obey ``(command, *args)`` from ``conn`` until ``stop``; ``niceness``
    below the priority it was started with (:data:`LOAD_NICENESS`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the benchmark process stops us through the pipe
    nice = lower_priority(niceness)
    session = open_session(ZenohSettings(mode="peer", listen=(endpoint,), connect=()))
    load = None
    try:
        load = Load(session, fleet)
        listening = listening_endpoints(session) if endpoint.endswith(":0") else [endpoint]
        conn.send({"ready": True, "nice": nice, "endpoint": listening[0]})
        while True:
            command, *args = conn.recv()
            if command == "stop":
                break
            try:
                conn.send(getattr(load, command)(*args))
            except Exception as error:  # tell the benchmark, which raises it; then stop
                conn.send({"error": f"{type(error).__name__}: {error}"})
                raise
    except EOFError:  # the benchmark process is gone
        pass
    finally:
        if load is not None:
            load.close()
        session.close()
