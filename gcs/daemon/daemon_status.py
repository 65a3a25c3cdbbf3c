"""The daemon's health as it publishes it (``DaemonStatus``): each vehicle's link, autopilot and control, every
counter of the engine, the plan runner and MAVLink, the newest step's tracks and the command age."""

from __future__ import annotations

import time

from gcs.adapters.mavlink_io import MavlinkCommander
from gcs.daemon.plan_runners import PlanRunner
from gcs.daemon.track_summary import summarise_track
from gcs.engine.engine import Engine
from gcs.engine.registry import LOST_AFTER_S
from protocols.status import MAX_STATUS_TRACKS, DaemonStatus, LinkState, VehicleStatus

__all__ = ["daemon_status", "AUTOPILOT_NAMES"]

AUTOPILOT_NAMES = {3: "ArduPilot", 12: "PX4"}
"""MAV_AUTOPILOT values the status names."""


def daemon_status(engine: Engine, scenario: str, commander: MavlinkCommander | None, plan_runner: PlanRunner | None,
                  uptime_s: float, now: float) -> DaemonStatus:
    """The daemon's health at loop time ``now``: vehicles, link state, counters, the newest step's tracks (the first
    :data:`~protocols.status.MAX_STATUS_TRACKS`)."""
    vehicles = []
    for vehicle_id, entry in engine.registry.entries.items():
        autopilot = control = None
        heartbeat: LinkState | None = None
        if commander is not None:
            link = commander.link(vehicle_id)
            autopilot = None if link.autopilot is None else AUTOPILOT_NAMES.get(link.autopilot)
            heartbeat = "unknown" if link.last_heartbeat_s is None else (
                "ok" if link.alive(now, LOST_AFTER_S) else "lost")
            control = commander.control(vehicle_id, now)
        vehicles.append(VehicleStatus(vehicle_id=vehicle_id, sysid=entry.config.sysid,
                                      link=engine.registry.link_state(vehicle_id, now),
                                      last_report_stamp_ns=entry.last_report_stamp_ns, reports=entry.reports,
                                      autopilot=autopilot, heartbeat=heartbeat,
                                      liveliness=engine.registry.liveliness_state(vehicle_id),
                                      control=control))
    counters = engine.counters_now()
    if plan_runner is not None:
        counters["plans_superseded"] = plan_runner.superseded
        counters["planner_restarts"] = getattr(plan_runner, "restarts", 0)
    if commander is not None:
        counters.update({f"mavlink.{k}": v for k, v in commander.counters().items()})
    return DaemonStatus(stamp_ns=time.time_ns(), uptime_s=uptime_s,
                        scenario=scenario, vehicles=tuple(vehicles),
                        counters={k: int(v) for k, v in counters.items() if v >= 0},
                        last_track_stamp_ns=engine.loop.last_track_stamp_ns,
                        tracks=tuple(summarise_track(t) for t in engine.tracks_now.values())[:MAX_STATUS_TRACKS],
                        command_age_ms_median=engine.command_ages.median_ms(),
                        command_age_ms_p99=engine.command_ages.p99_ms())
