"""The payload bridge's pure part: an autopilot's telemetry in, the vehicle's reports out.

``sim-vehicles payload`` (:mod:`sim_vehicles.payload_command`) gives a vehicle that
flies on a real or SITL autopilot (ArduPlane, PX4, or our own personalities) what a
simulated vehicle publishes: its ``NavReport``, the ``SensorReport`` of the
scenario's simulated target sensor, the target's ``TargetTruth``, and its liveliness.
This module owns no socket and reads no clock; the shell feeds it MAVLink messages
and the time.

What comes from where
---------------------
- **The telemetry**: GLOBAL_POSITION_INT, ATTITUDE and GPS_RAW_INT, read into each vehicle's pose and
  GPS status (:mod:`sim_vehicles.payload_telemetry`).
- **The scenario**: the target (its motion model, scripted path or roads, and its
  random stream from ``seed``, as in ``sim-vehicles run``), the city's buildings, the
  vehicle's sensor, ``report_rate_hz``, ``nav_rate_hz`` and ``physics_step_s``.

The sensor report is :meth:`sim_vehicles.scene.Scene.sensor_report` itself: the
bridge keeps a :class:`~sim_vehicles.scene.Scene` of the bridged vehicles, moves its
target one physics step at a time on the bridge's clock
(:meth:`~sim_vehicles.scene.Scene.skip_target`), and before each report sets the
vehicle's state to the pose from telemetry, so the line of sight, range limit and
noise are the scene's. The pose is the latest GLOBAL_POSITION_INT moved to the
report's time with its own velocity (and the heading with the turn rate).

The ``NavReport``: ``gps`` (that position as a fix, with the GPS_RAW_INT's fix type,
accuracy and satellites) when the last GPS_RAW_INT had a fix (``fix_type >= 2``);
``ins``, the distance flown (mean ground speed x interval) and the heading change
since the vehicle's previous nav report; the velocity when there is a fix (as the
simulated vehicles do); ``heading_rad`` and ``turn_rate_rad_s``.

Time
----
The bridge's clock is seconds since launch (``now_s``, monotonic, given by the
shell); telemetry is timed by its arrival on that clock, not by the autopilot's
``time_boot_ms``. Wire stamps are ``epoch_ns + elapsed``, with ``epoch_ns`` the Unix
wall time at launch: the bridge's wall clock, since a real aircraft flies in real
time. Stamps fall on whole physics steps, reports on multiples of their period.

Positions at lat = lon = 0, which an autopilot sends before its GPS has a fix, are dropped and counted
(``positions_without_fix``), and logged once.

Liveliness: a vehicle is alive while its last good GLOBAL_POSITION_INT is at most
``stale_after_s`` old; :meth:`PayloadBridge.advance` says when to declare its token
and when to withdraw it (and publishes nothing for it meanwhile). Bad telemetry
(:class:`~sim_vehicles.payload_telemetry.BadTelemetry`) is counted, logged and otherwise ignored.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import msgspec
import numpy as np

from gcs.config import Scenario
from gcs.core.geometry import wrap_angle
from gcs.core.world import World
from protocols.messages import GpsFix, InsIncrement, NavReport, SensorReport, TargetTruth
from sim_vehicles.payload_telemetry import BadTelemetry, GpsStatus, NoFix, Pose, VehicleTelemetry
from sim_vehicles.scene import Scene
from sim_vehicles.truth.fixed_wing import AirframeState

__all__ = ["Liveliness", "PayloadBridge", "Publication", "summary_line"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
_LOGGED_BAD = 10  # bad telemetry is logged for a vehicle's first few messages, then every hundredth


@dataclass(frozen=True)
class Publication:
    """A message to publish: ``kind`` ``"report"``, ``"nav"`` (``ident``: a vehicle) or ``"truth"`` (a target)."""

    ident: str
    kind: str
    message: SensorReport | NavReport | TargetTruth


@dataclass(frozen=True)
class Liveliness:
    """Declare (``alive``) or withdraw a vehicle's liveliness token."""

    vehicle_id: str
    alive: bool


def summary_line(vehicle_id: str, counts: Counter) -> str:
    """The closing summary's line for one vehicle's :attr:`PayloadBridge.counts`."""
    return (f"{vehicle_id}: {counts['messages']} MAVLink messages read, {counts['nav_reports']} nav reports, "
            f"{counts['reports']} sensor reports ({counts['detections']} detections), {counts['bad_telemetry']} bad "
            f"telemetry, {counts['positions_without_fix']} positions without a GPS fix, liveliness withdrawn "
            f"{counts['withdrawn']} times")


@dataclass
class _Bridged:
    """One bridged vehicle: its telemetry, counts, liveliness and previous nav report."""

    telemetry: VehicleTelemetry
    counts: Counter = field(default_factory=Counter)
    """messages, bad_telemetry, reports, detections, nav_reports, withdrawn (times)."""
    alive: bool = False
    nav_seq: int = 0
    last_nav: tuple[int, float, float] | None = None
    """(stamp_ns, heading_rad, ground speed m/s) of the previous nav report while alive."""


class PayloadBridge:
    """The reports of bridged vehicles against the scenario's simulated target.

    Parameters
    ----------
    scenario, world
        The scenario and its city.
    vehicle_ids : sequence of str
        The bridged vehicles (scenario ids).
    seed : int
        Seed of the target's and the sensors' random streams (as ``sim-vehicles run --seed``).
    stale_after_s : float
        Liveliness is withdrawn when the last good GLOBAL_POSITION_INT is older.
    base_dir : Path or None
        Where the scenario's relative files live.
    """

    def __init__(self, scenario: Scenario, world: World, vehicle_ids, seed: int, stale_after_s: float = 3.0,
                 base_dir: Path | None = None) -> None:
        self.scenario = scenario
        self.scene = Scene(scenario, world, seed, 0, base_dir, tuple(vehicle_ids))
        self.stale_after_s = float(stale_after_s)
        self.vehicles = {vid: _Bridged(VehicleTelemetry(self.scene.frame)) for vid in vehicle_ids}
        sim = scenario.simulation
        self._step_ns = round(sim.physics_step_s * NS_PER_S)
        self._periods_ns = {"report": round(NS_PER_S / sim.report_rate_hz), "nav": round(NS_PER_S / sim.nav_rate_hz)}
        self._next_ns = {"report": 0, "nav": 0}

    def start(self, epoch_ns: int) -> None:
        """Set the wire stamp of the bridge's time zero: the Unix wall time (ns) when its clock starts."""
        self.scene.epoch_ns = int(epoch_ns)

    @property
    def counts(self) -> dict[str, Counter]:
        """Per vehicle: MAVLink ``messages`` read, ``bad_telemetry``, ``positions_without_fix``, sensor ``reports``
        (``detections``),
        ``nav_reports``, and how often its liveliness was ``withdrawn``."""
        return {vid: bridged.counts for vid, bridged in self.vehicles.items()}

    def ingest(self, vehicle_id: str, message, now_s: float) -> bool:
        """One MAVLink message from the vehicle, received at ``now_s``; False (counted, logged) if it was bad."""
        bridged = self.vehicles[vehicle_id]
        bridged.counts["messages"] += 1
        try:
            bridged.telemetry.ingest(message, now_s)
        except NoFix:
            bridged.counts["positions_without_fix"] += 1
            if bridged.counts["positions_without_fix"] == 1:
                log.info("%s: positions at lat 0, lon 0 (no GPS fix yet) are dropped until it has a fix", vehicle_id)
            return False
        except BadTelemetry as error:
            bridged.counts["bad_telemetry"] += 1
            n = bridged.counts["bad_telemetry"]
            if n <= _LOGGED_BAD or n % 100 == 0:
                log.warning("%s: bad telemetry #%d ignored (%s): %s", vehicle_id, n, message.get_type(), error)
            return False
        return True

    def advance(self, now_s: float) -> list[Publication | Liveliness]:
        """Move the target up to ``now_s`` (physics steps) and say what is due on the way: liveliness changes,
        then at each report and nav period the fresh vehicles' reports and the target's truth."""
        out: list[Publication | Liveliness] = []
        now_ns = round(now_s * NS_PER_S)
        scene = self.scene
        while True:
            t = scene.elapsed_s
            out.extend(self._liveliness(t))
            if scene.elapsed_ns >= self._next_ns["report"]:
                self._next_ns["report"] = self._next(scene.elapsed_ns, "report")
                out.extend(self._sensor_reports(t))
                out.extend(Publication(truth.target_id, "truth", truth) for truth in scene.truths())
            if scene.elapsed_ns >= self._next_ns["nav"]:
                self._next_ns["nav"] = self._next(scene.elapsed_ns, "nav")
                out.extend(self._nav_reports(t))
            if scene.elapsed_ns + self._step_ns > now_ns:
                return out
            scene.skip_target(self._step_ns / NS_PER_S)

    def _next(self, elapsed_ns: int, kind: str) -> int:
        period = self._periods_ns[kind]
        return (elapsed_ns // period + 1) * period

    def _liveliness(self, now_s: float) -> list[Liveliness]:
        changes = []
        for vehicle_id, bridged in self.vehicles.items():
            fresh = bridged.telemetry.fresh(now_s, self.stale_after_s)
            if fresh != bridged.alive:
                bridged.alive = fresh
                if not fresh:
                    bridged.counts["withdrawn"] += 1
                    bridged.last_nav = None  # the next nav report starts the INS increments afresh
                log.info("%s: telemetry %s; liveliness %s", vehicle_id, "fresh" if fresh else "stale",
                         "declared" if fresh else "withdrawn")
                changes.append(Liveliness(vehicle_id, fresh))
        return changes

    def _sensor_reports(self, now_s: float) -> list[Publication]:
        out = []
        for vehicle_id, bridged in self.vehicles.items():
            if not bridged.alive:
                continue
            pose = bridged.telemetry.pose(now_s)
            vehicle = self.scene.vehicles[vehicle_id]
            vehicle.state = AirframeState(pose.position_enu_m, pose.heading_rad, pose.roll_rad,
                                          airspeed_mps=float(np.linalg.norm(pose.velocity_enu_mps[:2])),
                                          climb_rate_mps=float(pose.velocity_enu_mps[2]),
                                          turn_rate_rad_s=pose.turn_rate_rad_s, elapsed_s=now_s)
            vehicle.nav_position_enu_m, vehicle.nav_heading_rad = pose.position_enu_m, pose.heading_rad
            gps = bridged.telemetry.gps
            std = gps.h_acc_m if gps is not None and gps.fix_type >= 2 and math.isfinite(gps.h_acc_m) else None
            vehicle.nav_std_m = 0.0 if std is None else std
            report: SensorReport = self.scene.sensor_report(vehicle_id)
            if std is None:  # the autopilot's position without a fix: its accuracy is not known
                report = msgspec.structs.replace(report, vehicle_position_std_m=None)
            bridged.counts["reports"] += 1
            bridged.counts["detections"] += report.detected
            out.append(Publication(vehicle_id, "report", report))
        return out

    def _nav_reports(self, now_s: float) -> list[Publication]:
        out = []
        stamp = self.scene.stamp_ns
        for vehicle_id, bridged in self.vehicles.items():
            if not bridged.alive:
                continue
            pose = bridged.telemetry.pose(now_s)
            speed = float(np.hypot(pose.velocity_enu_mps[0], pose.velocity_enu_mps[1]))
            ins = None
            if bridged.last_nav is not None and stamp > bridged.last_nav[0]:
                last_stamp, last_heading, last_speed = bridged.last_nav
                dt = (stamp - last_stamp) / NS_PER_S
                ins = InsIncrement(dt_s=dt, distance_m=0.5 * (speed + last_speed) * dt,
                                   heading_change_rad=wrap_angle(pose.heading_rad - last_heading))
            bridged.last_nav = (stamp, pose.heading_rad, speed)
            fix = self._gps_fix(bridged.telemetry.gps, pose)
            velocity = None
            if fix is not None or ins is None:
                velocity = (float(pose.velocity_enu_mps[0]), float(pose.velocity_enu_mps[1]),
                            float(pose.velocity_enu_mps[2]))
            bridged.nav_seq += 1
            bridged.counts["nav_reports"] += 1
            out.append(Publication(vehicle_id, "nav", NavReport(
                vehicle_id=vehicle_id, seq=bridged.nav_seq, stamp_ns=stamp, gps=fix, ins=ins,
                velocity_enu_mps=velocity, heading_rad=wrap_angle(pose.heading_rad),
                turn_rate_rad_s=pose.turn_rate_rad_s)))
        return out

    def _gps_fix(self, gps: GpsStatus | None, pose: Pose) -> GpsFix | None:
        """The pose's position as a fix, with GPS_RAW_INT's figures, when that says there is a fix (>= 2D)."""
        if gps is None or gps.fix_type < 2 or not (math.isfinite(gps.h_acc_m) and gps.h_acc_m > 0.0):
            return None
        frame = self.scene.frame
        lat, lon, _ = frame.to_geodetic(pose.position_enu_m)
        v_acc = gps.v_acc_m if math.isfinite(gps.v_acc_m) and gps.v_acc_m > 0.0 else gps.h_acc_m
        return GpsFix(lat_deg=float(lat), lon_deg=float(lon), alt_m=frame.height_m + float(pose.position_enu_m[2]),
                      fix_type=gps.fix_type, h_acc_m=gps.h_acc_m, v_acc_m=v_acc, satellites=gps.satellites)
