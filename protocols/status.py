"""The daemon's health as published on ``gcs/status``: :class:`DaemonStatus` and its vehicles.

Frames, units and validation are as in :mod:`protocols.messages`, which re-exports both types.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

import msgspec
from msgspec import Meta

from protocols.base import Message
from protocols.fields import CommandAgeMs, Count, CounterName, Ident, StampNs, Text, UptimeS

__all__ = ["DaemonStatus", "VehicleStatus"]


class VehicleStatus(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The daemon's view of one vehicle, part of :class:`DaemonStatus`.

    Attributes
    ----------
    vehicle_id : str
    sysid : int or None
        MAVLink system id (1..250), if a MAVLink link is configured.
    link : {"ok", "lost", "unknown"}
        The vehicle is alive: its liveliness token is declared or its MAVLink heartbeat recent.
    last_report_stamp_ns : int or None
        ``stamp_ns`` of the last accepted report, if any.
    reports : int
        Accepted reports so far.
    autopilot : str or None
        Autopilot description, if known (e.g. ``"ArduPilot"``, ``"PX4"``).
    heartbeat : {"ok", "lost", "unknown"} or None
        The MAVLink heartbeat alone (within 5 s), if a MAVLink link is configured.
    liveliness : {"ok", "lost", "unknown"} or None
        The Zenoh liveliness token alone (declared, withdrawn, never seen).
    control : str or None
        Who flies it, if a MAVLink link is configured: ``daemon``, ``switching``, ``waiting: REASON``
        (held back by the takeover guard), ``handed back: WHY`` or ``pilot``.
    """

    vehicle_id: Ident
    sysid: Annotated[int, Meta(ge=1, le=250)] | None = None
    link: Literal["ok", "lost", "unknown"]
    last_report_stamp_ns: StampNs | None = None
    reports: Count
    autopilot: Text | None = None
    heartbeat: Literal["ok", "lost", "unknown"] | None = None
    liveliness: Literal["ok", "lost", "unknown"] | None = None
    control: Text | None = None


class DaemonStatus(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Health of the ``gcs`` daemon (published and queryable).

    Attributes
    ----------
    stamp_ns : int
        Time of the status.
    uptime_s : float
        Seconds since the daemon started (>= 0).
    scenario : str
        Scenario name.
    vehicles : tuple of VehicleStatus
    counters : dict of str to int
        Accepted and rejected message counts by reason (non-negative).
    last_track_stamp_ns : int or None
        ``stamp_ns`` of the last published track, if any.
    command_age_ms_median, command_age_ms_p99 : float or None
        Median and 99th percentile of the steering commands' age, ms: the vehicle time at which a
        command was flown less the stamp of the decision step its plan came from, over the newest
        commands (:class:`gcs.engine.memory.CommandAges`); None before the first command.
    """

    VERSION: ClassVar[int] = 3
    """Version 2: :class:`VehicleStatus` says the heartbeat, the liveliness and who flies the vehicle.
    Version 3: the steering commands' age (``command_age_ms_median``, ``command_age_ms_p99``)."""

    stamp_ns: StampNs
    uptime_s: UptimeS
    scenario: Text
    vehicles: Annotated[tuple[VehicleStatus, ...], Meta(max_length=256)]
    counters: dict[CounterName, Count] = msgspec.field(default_factory=dict)
    last_track_stamp_ns: StampNs | None = None
    command_age_ms_median: CommandAgeMs | None = None
    command_age_ms_p99: CommandAgeMs | None = None
