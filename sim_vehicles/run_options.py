"""What ``sim-vehicles run`` is asked to do (:class:`RunOptions`) and what it did (:class:`RunSummary`)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from gcs.adapters.zenoh_session import ZenohSettings

__all__ = ["RunOptions", "RunSummary"]


@dataclass(frozen=True)
class RunOptions:
    """How to run the scene.

    Attributes
    ----------
    rate : float
        Simulation seconds per wall-clock second.
    duration_s : float or None
        Simulation seconds to run; None runs until stopped.
    seed : int
    epoch_ns : int
        Wire stamp of simulation time zero.
    mavlink : dict of vehicle id -> connection string, or None
        Per-vehicle MAVLink endpoints (None: no MAVLink at all).
    signing_key : bytes or None
        MAVLink 2 signing key for every link.
    zenoh : ZenohSettings or None
        None: publish nothing over Zenoh.
    prefix : str
        Zenoh key prefix.
    only : tuple of vehicle ids, or None
        Fly only these vehicles (e.g. one per process); the target's truth is
        published by the process that flies the scenario's first vehicle.
    start_at_ns : int or None
        Start the simulation clock at this Unix time (ns), after the waits above, so
        that vehicles flown by several processes keep one clock. A time already past
        joins a run in flight (a vehicle process restarted after a crash): the target
        is first moved, publishing nothing, to the clock's time (with ``lockstep``, to
        the median of the others' newest reports, when some are heard), so that it
        is where the other processes have it; the vehicles start afresh from their
        start points, and their liveliness tokens are declared once the scene has
        joined. ``duration_s`` still counts from zero.
    start_with : tuple of vehicle ids
        Instead of ``start_at_ns``: start the simulation clock once each of these
        vehicles (flown by other processes, started the same way) has its liveliness
        token up, however long the machine takes to start them
        (:func:`sim_vehicles.lockstep.wait_for_vehicles`). The processes must hear
        each other's tokens (clients of one router, say: peers connected only to a
        third peer do not).
    wait_for_subscriber_s : float
        Before the clock starts, wait up to this long (wall time) for subscribers
        to every key (a ground station), so that the first reports are not
        published into the void while the connection comes up.
    lockstep : bool
        Keep one clock with the other vehicles under the prefix (:mod:`sim_vehicles.lockstep`).
    wait_for_plans : bool
        Hold each step until the ground station's plan of the decision step reached has come
        (:mod:`sim_vehicles.plan_clock`).
    """

    rate: float = 1.0
    duration_s: float | None = None
    seed: int = 0
    epoch_ns: int = 0
    mavlink: dict[str, str] | None = None
    signing_key: bytes | None = None
    zenoh: ZenohSettings | None = None
    prefix: str = "gcs"
    only: tuple[str, ...] | None = None
    wait_for_subscriber_s: float = 0.0
    start_at_ns: int | None = None
    start_with: tuple[str, ...] = ()
    lockstep: bool = False
    wait_for_plans: bool = False


@dataclass
class RunSummary:
    """What a run did, for the closing summary and tests."""

    simulated_s: float = 0.0
    wall_s: float = 0.0
    steps: int = 0
    late_steps: int = 0
    held_steps: int = 0
    held_s: float = 0.0
    plan_held_steps: int = 0
    plan_held_s: float = 0.0
    plan_waits_timed_out: int = 0
    reports: Counter = field(default_factory=Counter)
    detections: Counter = field(default_factory=Counter)
    nav_reports: Counter = field(default_factory=Counter)
    modes: dict[str, str] = field(default_factory=dict)
    mavlink: Counter = field(default_factory=Counter)
    unpublishable: Counter = field(default_factory=Counter)

    def lines(self) -> list[str]:
        """Human-readable summary."""
        out = [f"simulated {self.simulated_s:.1f} s in {self.wall_s:.1f} s of wall time "
               f"({self.steps} steps, {self.late_steps} started late"
               + (f", {self.held_steps} held {self.held_s:.1f} s for the other vehicles" if self.held_steps else "")
               + (f", {self.plan_held_steps} held {self.plan_held_s:.1f} s for plans "
                  f"({self.plan_waits_timed_out} timed out)" if self.plan_held_steps else "") + ")"]
        for vehicle_id, mode in self.modes.items():
            out.append(f"  {vehicle_id}: mode {mode}, {self.reports[vehicle_id]} reports "
                       f"({self.detections[vehicle_id]} detections), {self.nav_reports[vehicle_id]} nav reports")
        if self.mavlink:
            out.append("  MAVLink: " + ", ".join(f"{k} {v}" for k, v in sorted(self.mavlink.items())))
        return out
