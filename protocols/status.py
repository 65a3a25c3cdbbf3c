"""The daemon's health as published on ``gcs/status``: :class:`DaemonStatus`, its vehicles and its tracks.

Frames, units and validation are as in :mod:`protocols.messages`, which re-exports these types.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

import msgspec
from msgspec import Meta

from protocols.base import Message
from protocols.fields import (CommandAgeMs, Count, CounterName, Ident, PositionM, SpeedMps, StampNs, StdOrZeroM,
                              Text, UptimeS)

__all__ = ["MAX_STATUS_TRACKS", "DaemonStatus", "LinkState", "TrackSummary", "VehicleStatus"]

LinkState = Literal["ok", "lost", "unknown"]
"""A vehicle's link: ``ok``, ``lost`` (it was heard, and is no longer) or ``unknown`` (never heard)."""


MAX_STATUS_TRACKS = 256
"""Tracks a :class:`DaemonStatus` lists at most."""

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
    link: LinkState
    last_report_stamp_ns: StampNs | None = None
    reports: Count
    autopilot: Text | None = None
    heartbeat: LinkState | None = None
    liveliness: LinkState | None = None
    control: Text | None = None


class TrackSummary(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One of the daemon's current tracks in brief, part of :class:`DaemonStatus`.

    The full estimate is the :class:`~protocols.messages.TrackEstimate` on ``<prefix>/track/<target_id>``.

    Attributes
    ----------
    target_id : str
    stamp_ns : int
        Time the track's newest estimate is valid for.
    x_m, y_m : float
        Estimated position, metres ENU.
    position_std_m : float
        1-sigma of the position along its worst horizontal axis (>= 0), metres: the square root of
        the largest eigenvalue of the estimate's 2x2 (x, y) covariance block.
    speed_mps : float or None
        Estimated ground speed (>= 0), m/s; None when the track's model has no velocity.
    contributing_vehicles : tuple of str
        Vehicles whose reports went into the estimate.
    """

    target_id: Ident
    stamp_ns: StampNs
    x_m: PositionM
    y_m: PositionM
    position_std_m: StdOrZeroM
    speed_mps: SpeedMps | None = None
    contributing_vehicles: Annotated[tuple[Ident, ...], Meta(max_length=256)]


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
    tracks : tuple of TrackSummary
        The daemon's current tracks, one per target (empty before the first track).
    """

    VERSION: ClassVar[int] = 4
    """Version 2: :class:`VehicleStatus` says the heartbeat, the liveliness and who flies the vehicle.
    Version 3: the steering commands' age (``command_age_ms_median``, ``command_age_ms_p99``).
    Version 4: the current tracks (``tracks``); version 3 still decodes (:mod:`protocols.legacy`)."""

    stamp_ns: StampNs
    uptime_s: UptimeS
    scenario: Text
    vehicles: Annotated[tuple[VehicleStatus, ...], Meta(max_length=256)]
    counters: dict[CounterName, Count] = msgspec.field(default_factory=dict)
    last_track_stamp_ns: StampNs | None = None
    command_age_ms_median: CommandAgeMs | None = None
    command_age_ms_p99: CommandAgeMs | None = None
    tracks: Annotated[tuple[TrackSummary, ...], Meta(max_length=MAX_STATUS_TRACKS)] = ()
