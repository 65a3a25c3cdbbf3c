"""What the engine knows about each vehicle of the roster, and which ones it plans for.

A vehicle is **alive** while its Zenoh liveliness token is declared or its
MAVLink heartbeat is recent (within ``lost_after_s``, 5 s: MAVProxy's
link-loss convention). A withdrawn token (the vehicle's process ended or was
killed: Zenoh withdraws it within milliseconds on loopback) makes it lost at
once, unless its MAVLink heartbeat goes on after the withdrawal; a silent loss
of both links shows after the heartbeat's 5 s or Zenoh's lease (10 s). It is **plannable** when alive and its navigation is
known: a position (from its reports) and a heading (from its nav reports).
The planner state comes only from stamped Zenoh data, never from MAVLink
telemetry, so that a replay of the same reports plans the same way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.config import VehicleConfig
from gcs.core.kinematics import VehicleState
from protocols.messages import NavReport, SensorReport
from protocols.status import LinkState

__all__ = ["VehicleEntry", "Registry", "VehicleSnapshot", "LOST_AFTER_S"]

LOST_AFTER_S = 5.0
AFTER_WITHDRAWAL_S = 0.5
"""A heartbeat must be this much younger than a withdrawn liveliness token to keep the vehicle alive (one
sent just before the process died may be read just after its token went)."""
NS_PER_S = 1_000_000_000


@dataclass
class VehicleEntry:
    """One roster vehicle: configuration, liveliness and its latest navigation."""

    config: VehicleConfig
    token: bool = False
    token_changed_s: float | None = None
    reports: int = 0
    last_report_stamp_ns: int | None = None
    position_enu_m: tuple[float, float, float] | None = None
    position_stamp_ns: int | None = None
    heading_rad: float | None = None
    velocity_enu_mps: NDArray[np.float64] | None = None
    nav_stamp_ns: int | None = None
    was_alive: bool = False


class Registry:
    """The roster's entries, in scenario order."""

    def __init__(self, vehicles: list[VehicleConfig], heartbeat_age: Callable[[str, float], float | None]) -> None:
        """``heartbeat_age(vehicle_id, now_s)`` is the age of its last MAVLink heartbeat (None: never)."""
        self.entries = {v.id: VehicleEntry(v) for v in vehicles}
        self.heartbeat_age = heartbeat_age

    @property
    def ids(self) -> list[str]:
        """Vehicle ids in roster order."""
        return list(self.entries)

    def on_liveliness(self, vehicle_id: str, alive: bool, now_s: float) -> None:
        """A liveliness token was declared (True) or withdrawn (False)."""
        entry = self.entries.get(vehicle_id)
        if entry is not None:
            entry.token, entry.token_changed_s = alive, now_s

    def on_report(self, report: SensorReport) -> None:
        """An accepted sensor report: the vehicle's own position at the report's stamp (unless a newer one is
        known already: reports may arrive out of order)."""
        entry = self.entries[report.vehicle_id]
        entry.reports += 1
        if entry.last_report_stamp_ns is not None and report.stamp_ns < entry.last_report_stamp_ns:
            return
        entry.last_report_stamp_ns = report.stamp_ns
        entry.position_enu_m = report.vehicle_position_enu_m  # an array only when asked (position_at)
        entry.position_stamp_ns = report.stamp_ns

    def on_nav(self, nav: NavReport) -> None:
        """An accepted nav report: heading and velocity (unless a newer nav report is known already).

        The heading the planner flies on (wang2012 eq. 1 moves a vehicle along its heading over the
        ground) is the course over the ground, the velocity's direction, when the report has a velocity
        of more than 1 m/s: a plane's nose points off its track in a wind, and in a turn by its
        sideslip (ArduPilot SITL's plane: several degrees), and a path started on the nose's heading
        is that far off the vehicle's. Without a velocity it is the reported heading."""
        entry = self.entries[nav.vehicle_id]
        if entry.nav_stamp_ns is not None and nav.stamp_ns < entry.nav_stamp_ns:
            return
        if nav.velocity_enu_mps is not None and math.hypot(*nav.velocity_enu_mps[:2]) > 1.0:
            entry.heading_rad = math.atan2(nav.velocity_enu_mps[1], nav.velocity_enu_mps[0])
        elif nav.heading_rad is not None:
            entry.heading_rad = nav.heading_rad
        if nav.velocity_enu_mps is not None:
            entry.velocity_enu_mps = np.asarray(nav.velocity_enu_mps, dtype=np.float64)
        entry.nav_stamp_ns = nav.stamp_ns

    def alive(self, vehicle_id: str, now_s: float) -> bool:
        """Liveliness token declared, or a MAVLink heartbeat within :data:`LOST_AFTER_S`; after the token
        was withdrawn, only a heartbeat heard more than :data:`AFTER_WITHDRAWAL_S` later counts (a killed
        vehicle process is lost at once, not when its last heartbeat has aged)."""
        entry = self.entries[vehicle_id]
        if entry.token:
            return True
        age = self.heartbeat_age(vehicle_id, now_s)
        if age is None or age > LOST_AFTER_S:
            return False
        return entry.token_changed_s is None or now_s - age > entry.token_changed_s + AFTER_WITHDRAWAL_S

    def liveliness_state(self, vehicle_id: str) -> LinkState:
        """The Zenoh liveliness token alone: ``ok`` (declared), ``lost`` (withdrawn) or ``unknown`` (never seen)."""
        entry = self.entries[vehicle_id]
        if entry.token:
            return "ok"
        return "unknown" if entry.token_changed_s is None else "lost"

    def link_state(self, vehicle_id: str, now_s: float) -> LinkState:
        """``ok``, ``lost`` (was alive, is not) or ``unknown`` (never heard of)."""
        entry = self.entries[vehicle_id]
        if self.alive(vehicle_id, now_s):
            entry.was_alive = True
            return "ok"
        return "lost" if entry.was_alive or entry.token_changed_s is not None else "unknown"

    def plannable(self, now_s: float) -> list[str]:
        """Alive vehicles with a known position and heading, in roster order."""
        return [vid for vid, e in self.entries.items()
                if self.alive(vid, now_s) and e.position_enu_m is not None and e.heading_rad is not None]

    def vehicle_state(self, vehicle_ids: list[str], stamp_ns: int) -> VehicleState:
        """The planner's view of these vehicles at ``stamp_ns``: reported positions and nav headings,
        the scenario's speeds and altitudes (wang2012 eq. 1 holds them constant)."""
        return self.snapshot(vehicle_ids).at(stamp_ns)

    def snapshot(self, vehicle_ids: Sequence[str]) -> VehicleSnapshot:
        """What is known of these vehicles now, to make their :meth:`vehicle_state` of later (cheap:
        a reference to each entry's values, which are replaced, never changed in place)."""
        rows = []
        for vehicle_id in vehicle_ids:
            e = self.entries[vehicle_id]
            if e.position_enu_m is None or e.heading_rad is None:
                raise ValueError(f"{vehicle_id} has reported no position and heading yet: it cannot be planned for")
            rows.append((e.config, e.position_enu_m, e.position_stamp_ns, e.velocity_enu_mps, e.heading_rad))
        return VehicleSnapshot(tuple(rows))

    def position_at(self, vehicle_id: str, stamp_ns: int) -> NDArray[np.float64]:
        """Position (3,) at ``stamp_ns``: the last reported one, moved on with the velocity if older."""
        entry = self.entries[vehicle_id]
        if entry.position_enu_m is None:
            raise ValueError(f"{vehicle_id} has reported no position yet")
        return _moved(entry.position_enu_m, entry.position_stamp_ns, entry.velocity_enu_mps, stamp_ns)


def _moved(position_enu_m: tuple[float, float, float], position_stamp_ns: int | None,
           velocity_enu_mps: NDArray[np.float64] | None, stamp_ns: int) -> NDArray[np.float64]:
    """A reported position (3,) moved on to ``stamp_ns`` with the velocity, when it is older by at most 5 s."""
    position = np.array(position_enu_m, dtype=np.float64)
    if velocity_enu_mps is not None and position_stamp_ns is not None:
        dt = (stamp_ns - position_stamp_ns) / NS_PER_S
        if 0.0 < dt <= 5.0:
            position[:2] += velocity_enu_mps[:2] * dt
    return position


@dataclass(frozen=True)
class VehicleSnapshot:
    """Vehicles as the registry knew them at one moment (:meth:`Registry.snapshot`): per vehicle its
    configuration, last reported position and its stamp, nav velocity and heading."""

    rows: tuple[tuple[VehicleConfig, tuple[float, float, float], int | None, NDArray[np.float64] | None, float], ...]

    def at(self, stamp_ns: int) -> VehicleState:
        """:meth:`Registry.vehicle_state` at ``stamp_ns`` from what was known then."""
        positions = np.array([_moved(position, position_stamp, velocity, stamp_ns)
                              for _, position, position_stamp, velocity, _ in self.rows])
        return VehicleState(positions[:, :2], np.array([row[4] for row in self.rows]),
                            np.array([row[0].speed_mps for row in self.rows]),
                            np.array([row[0].altitude_m for row in self.rows]))
