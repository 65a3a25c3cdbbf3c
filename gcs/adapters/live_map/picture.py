"""The operator's picture: what the live map shows, built from the wire messages alone.

:class:`Picture` is fed every message the daemon receives (sensor and nav
reports, the simulator's truth) and every message it publishes (tracks, plans,
status), or, in ``gcs replay --view``, every message of a recording, and keeps
just what the page draws: each vehicle's latest position, heading, detection
and a trail; the newest track per target with its prediction, while it is
published (:data:`TRACK_STALE_STEPS`); each vehicle's planned path; the truth and
its trail; the track error against the truth; and, on a federation member, the federation's areas and targets
(:mod:`~gcs.adapters.live_map.federation_view`).
:meth:`Picture.snapshot` turns that into two plain dicts (JSON-ready), the
``/api/tracks`` and ``/api/status`` documents of :mod:`gcs.adapters.web`; the
page's own format is described in ``docs/live_map.md``.

No I/O and no clock: times are the messages' stamps, and the caller passes the
status. The daemon calls it from its loop thread and may call it from a
planning thread; a lock keeps the two apart.

Frames: ENU metres about the scenario's origin, as on the wire; a vehicle's
position is its GPS fix converted with the scenario's :class:`LocalFrame` (at
the nav rate) or, when newer or without a fix, the position it reported with
its last sensor report.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from gcs.config import Scenario
from gcs.core.geometry import LocalFrame
from gcs.core.world import World
from gcs.engine.federation import PublishMemberTracks
from gcs.adapters.live_map.federation_view import federation_document
from gcs.adapters.live_map.picture_geometry import TRAIL_POINTS, TRAIL_STEP_S, Trail, ellipse, world_geometry
from gcs.adapters.live_map.picture_geometry import rounded as _r
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.federation import MemberTracks
from protocols.messages import (DaemonStatus, Message, NavReport, PlanCommand, SensorReport, TargetTruth,
                                TrackEstimate, VehicleStatus)

__all__ = ["Picture", "TRACK_STALE_STEPS", "TRAIL_POINTS", "TRAIL_STEP_S"]

NS_PER_S = 1_000_000_000
MAX_VEHICLES = 1000
"""Vehicles tracked for the page; ids beyond these are counted, not drawn (bounded memory)."""
LOST_AFTER_S = 5.0
"""Without a status (replay), a vehicle is ``ok`` while its data is at most this old in stamp time."""
TRACK_STALE_STEPS = 2.5
"""A target's track leaves the map (with its ellipse, prediction and trail) once its stamp is this many decision
steps (the scenario's ``time.step_s``) older than the newest stamp the picture has seen: a track is published
every step while the tracker keeps it, so one that misses two steps and a half has been deleted (and when every
track has been, the reports' stamps go on)."""


@dataclass
class _Vehicle:
    """What the page knows of one vehicle."""

    position: tuple[float, float, float] | None = None
    fix: tuple[float, float, float] | None = None  # a newer GPS fix (lat, lon, alt) not converted to ENU yet
    stamp_ns: int | None = None
    heading_rad: float | None = None
    detected: bool | None = None
    reports: int = 0
    token: bool | None = None
    plan: PlanCommand | None = None
    trail: Trail = field(default_factory=Trail)


@dataclass
class _Target:
    """One target: newest track, newest truth, their trails, and the track's error against the truth."""

    track: TrackEstimate | None = None
    truth: TargetTruth | None = None
    track_trail: Trail = field(default_factory=Trail)
    truth_trail: Trail = field(default_factory=Trail)
    truth_at: dict[int, tuple[float, float]] = field(default_factory=dict)
    unscored: deque = field(default_factory=lambda: deque(maxlen=16))
    squares: float = 0.0
    scored: int = 0
    last_error_m: float | None = None


class Picture:
    """See the module docstring. ``observe`` and ``observe_wire`` feed it; ``snapshot`` reads it."""

    def __init__(self, scenario: Scenario, world: World, mode: str = "live") -> None:
        self.scenario, self.mode = scenario, mode
        self.world = world_geometry(scenario, world)
        self.frame = LocalFrame(scenario.origin.lat_deg, scenario.origin.lon_deg, scenario.origin.height_m)
        self.tolerance_ns = round(scenario.time.step_s * NS_PER_S / 10)
        self.track_stale_ns = round(TRACK_STALE_STEPS * scenario.time.step_s * NS_PER_S)
        self.vehicles: dict[str, _Vehicle] = {v.id: _Vehicle() for v in scenario.vehicles}
        self.targets: dict[str, _Target] = {}
        self.status: DaemonStatus | None = None
        self.newest_ns: int | None = None
        self.first_ns: int | None = None
        self.trail_epoch_ns: int | None = None
        """The first stamp seen; trail points' times count from it (fixed, where an older message moves first_ns)."""
        self.counters: dict[str, int] = {}
        self.federation: dict | None = None
        """The newest federation view (:func:`federation_document`); None when the daemon is no federation member."""
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ input

    def _count(self, name: str) -> None:
        """Count an event (the caller holds the lock)."""
        self.counters[name] = self.counters.get(name, 0) + 1

    def observe_wire(self, payload: bytes, encoding: str) -> None:
        """A message as it travels (exact payload and Zenoh encoding); undecodable ones are counted."""
        try:
            message = decode(payload, encoding)
        except ProtocolError:
            with self._lock:
                self._count("picture.rejected")
            return
        self.observe(message)

    def observe(self, message: Message) -> None:
        """A decoded, valid message of any type; types the page does not draw are ignored."""
        with self._lock:
            if isinstance(message, (SensorReport, NavReport, TargetTruth, TrackEstimate)):
                stamp = message.stamp_ns
                self.newest_ns = stamp if self.newest_ns is None else max(self.newest_ns, stamp)
                self.first_ns = stamp if self.first_ns is None else min(self.first_ns, stamp)
                self.trail_epoch_ns = stamp if self.trail_epoch_ns is None else self.trail_epoch_ns
            if isinstance(message, SensorReport):
                self._on_report(message)
            elif isinstance(message, NavReport):
                self._on_nav(message)
            elif isinstance(message, PlanCommand):
                vehicle = self._vehicle(message.vehicle_id)
                if vehicle is not None and (vehicle.plan is None or message.stamp_ns >= vehicle.plan.stamp_ns):
                    vehicle.plan = message
            elif isinstance(message, TrackEstimate):
                self._on_track(message)
            elif isinstance(message, TargetTruth):
                self._on_truth(message)
            elif isinstance(message, DaemonStatus):
                self.status = message

    def observe_federation(self, published: PublishMemberTracks, members: Mapping[str, MemberTracks]) -> None:
        """A federation member's picture of a decision step, with the other members' newest messages; an older
        picture than the one held is ignored."""
        document = federation_document(published, members)
        with self._lock:
            if self.federation is None or document["stamp_ns"] >= self.federation["stamp_ns"]:
                self.federation = document

    def on_liveliness(self, vehicle_id: str, alive: bool) -> None:
        """A vehicle's liveliness token appeared or went (replay: the status comes from it)."""
        with self._lock:
            vehicle = self._vehicle(vehicle_id)
            if vehicle is not None:
                vehicle.token = alive

    @property
    def _epoch_ns(self) -> int:
        """:attr:`trail_epoch_ns`, which the first stamped message sets, before any trail point is added."""
        if self.trail_epoch_ns is None:
            raise RuntimeError("a trail point before the first stamped message")
        return self.trail_epoch_ns

    def _vehicle(self, vehicle_id: str) -> _Vehicle | None:
        vehicle = self.vehicles.get(vehicle_id)
        if vehicle is None:
            if len(self.vehicles) >= MAX_VEHICLES:
                self._count("picture.vehicles_not_drawn")
                return None
            vehicle = self.vehicles[vehicle_id] = _Vehicle()
        return vehicle

    def _move(self, vehicle: _Vehicle, stamp_ns: int, position: tuple[float, float, float]) -> None:
        if vehicle.stamp_ns is None or stamp_ns >= vehicle.stamp_ns:
            vehicle.position, vehicle.fix, vehicle.stamp_ns = position, None, stamp_ns
            vehicle.trail.add(stamp_ns, position[0], position[1], self._epoch_ns)

    def _enu(self, fixes: list[tuple[float, float, float]]) -> np.ndarray:
        lat, lon, alt = np.array(fixes, dtype=np.float64).T
        return self.frame.to_enu(lat, lon, alt).reshape(-1, 3)

    def _fix(self, vehicle: _Vehicle, stamp_ns: int, fix: tuple[float, float, float]) -> None:
        """A GPS fix: converted to ENU now if the trail takes it, else when a snapshot needs it (at
        five times a second, not at the nav rate of every vehicle)."""
        if vehicle.stamp_ns is not None and stamp_ns < vehicle.stamp_ns:
            return
        if vehicle.trail.due(stamp_ns):
            self._move(vehicle, stamp_ns, _xyz(self._enu([fix])[0]))
        else:
            vehicle.fix, vehicle.stamp_ns = fix, stamp_ns

    def _on_report(self, report: SensorReport) -> None:
        vehicle = self._vehicle(report.vehicle_id)
        if vehicle is None:
            return
        vehicle.reports += 1
        vehicle.detected = report.detected
        self._move(vehicle, report.stamp_ns, _xyz(report.vehicle_position_enu_m))

    def _on_nav(self, nav: NavReport) -> None:
        vehicle = self._vehicle(nav.vehicle_id)
        if vehicle is None:
            return
        if nav.heading_rad is not None:
            vehicle.heading_rad = nav.heading_rad
        elif nav.velocity_enu_mps is not None and math.hypot(*nav.velocity_enu_mps[:2]) > 1.0:
            vehicle.heading_rad = math.atan2(nav.velocity_enu_mps[1], nav.velocity_enu_mps[0])
        if nav.gps is not None and nav.gps.fix_type >= 2:
            self._fix(vehicle, nav.stamp_ns, (nav.gps.lat_deg, nav.gps.lon_deg, nav.gps.alt_m))

    def _target(self, target_id: str) -> _Target:
        target = self.targets.get(target_id)
        if target is None:
            target = self.targets[target_id] = _Target()
        return target

    def _on_track(self, track: TrackEstimate) -> None:
        target = self._target(track.target_id)
        if target.track is not None and track.stamp_ns < target.track.stamp_ns:
            return
        if target.track is not None and track.stamp_ns - target.track.stamp_ns > self.track_stale_ns:
            target.track_trail = Trail()  # a new track under the id of one that left the map: a trail of its own
        target.track = track
        target.track_trail.add(track.stamp_ns, track.state[0], track.state[1], self._epoch_ns)
        if not self._score(target, track):
            target.unscored.append(track)

    def _on_truth(self, truth: TargetTruth) -> None:
        target = self._target(truth.target_id)
        target.truth_at[truth.stamp_ns] = truth.position_enu_m
        if len(target.truth_at) > 4096:
            del target.truth_at[min(target.truth_at)]
        if target.truth is None or truth.stamp_ns >= target.truth.stamp_ns:
            target.truth = truth
            target.truth_trail.add(truth.stamp_ns, *truth.position_enu_m, self._epoch_ns)
        for track in [t for t in target.unscored if abs(t.stamp_ns - truth.stamp_ns) <= self.tolerance_ns]:
            target.unscored.remove(track)
            self._score(target, track)

    def _score(self, target: _Target, track: TrackEstimate) -> bool:
        """Add the track's position error against the truth at its stamp (within a tenth of a step)."""
        truth = target.truth_at.get(track.stamp_ns)
        if truth is None:
            near = [s for s in target.truth_at if abs(s - track.stamp_ns) <= self.tolerance_ns]
            if not near:
                return False
            truth = target.truth_at[min(near, key=lambda s: abs(s - track.stamp_ns))]
        error = math.hypot(track.state[0] - truth[0], track.state[1] - truth[1])
        target.squares += error**2
        target.scored += 1
        target.last_error_m = error
        return True

    # ----------------------------------------------------------------- output

    def _link(self, vehicle: _Vehicle, entry: VehicleStatus | None) -> str:
        """The daemon's word when it has one; else lost with its token withdrawn or data older than
        :data:`LOST_AFTER_S` (in stamp time), ok with newer data or a token."""
        if entry is not None:
            return entry.link
        if vehicle.token is False:
            return "lost"
        if vehicle.stamp_ns is not None and self.newest_ns is not None:
            return "ok" if (self.newest_ns - vehicle.stamp_ns) <= LOST_AFTER_S * NS_PER_S else "lost"
        return "ok" if vehicle.token else "unknown"

    def snapshot(self, status: DaemonStatus | None = None, extra: dict | None = None) -> tuple[dict, dict]:
        """The ``/api/tracks`` and ``/api/status`` documents.

        ``status`` is the daemon's own (link states and counters); without one
        (replay) the newest recorded ``DaemonStatus`` is used if any, and links
        are derived from liveliness tokens and data age. ``extra`` is merged
        into the status document (e.g. the replay's clock). A federation member's tracks document has a
        ``federation`` part (:mod:`~gcs.adapters.live_map.federation_view`). Trails are
        ``msgspec.Raw`` JSON arrays: :func:`encode_json` embeds them as they are.
        """
        with self._lock:
            pending = [v for v in self.vehicles.values() if v.fix is not None]
            if pending:  # the newest fixes, converted in one call
                for vehicle, enu in zip(pending, self._enu([v.fix for v in pending if v.fix is not None])):
                    vehicle.position, vehicle.fix = (float(enu[0]), float(enu[1]), float(enu[2])), None
            status = status if status is not None else self.status
            links = {} if status is None else {entry.vehicle_id: entry for entry in status.vehicles}
            vehicles = []
            for vehicle_id, v in self.vehicles.items():
                plan = v.plan
                vehicles.append({
                    "id": vehicle_id, "link": self._link(v, links.get(vehicle_id)),
                    "x": None if v.position is None else _r(v.position[0]),
                    "y": None if v.position is None else _r(v.position[1]),
                    "z": None if v.position is None else _r(v.position[2]),
                    "heading_rad": None if v.heading_rad is None else round(v.heading_rad, 4),
                    "stamp_ns": v.stamp_ns, "detected": v.detected, "reports": v.reports,
                    "trail": v.trail.encoded(),
                    "plan": [] if plan is None else [[_r(x), _r(y)] for x, y in plan.planned_path_enu_m],
                    "plan_stamp_ns": None if plan is None else plan.stamp_ns,
                    "planner": None if plan is None else plan.planner,
                })
            tracks, truths, errors = [], [], {}
            fresh_ns = self._forget_stale_tracks()
            for target_id, t in self.targets.items():
                if t.track is not None and t.track.stamp_ns >= fresh_ns:
                    tracks.append(self._track(t.track, t.track_trail))
                if t.truth is not None:
                    truths.append({"target_id": target_id, "stamp_ns": t.truth.stamp_ns,
                                   "x": _r(t.truth.position_enu_m[0]), "y": _r(t.truth.position_enu_m[1]),
                                   "trail": t.truth_trail.encoded()})
                if t.scored:
                    errors[target_id] = {"rmse_m": round(math.sqrt(t.squares / t.scored), 2), "scored": t.scored,
                                         "last_error_m": None if t.last_error_m is None else round(t.last_error_m, 2)}
            document: dict = {"mode": self.mode, "stamp_ns": self.newest_ns, "trail_epoch_ns": self.trail_epoch_ns,
                              "vehicles": vehicles, "tracks": tracks, "truth": truths}
            if self.federation is not None:
                document["federation"] = self.federation
            counters = dict(status.counters) if status is not None else {}
            counters.update(self.counters)
            summary = {
                "mode": self.mode, "scenario": self.scenario.name, "stamp_ns": self.newest_ns,
                "first_stamp_ns": self.first_ns,
                "uptime_s": None if status is None else round(status.uptime_s, 1),
                "vehicles": [{"id": vehicle_id, "link": v["link"], "reports": v["reports"], "detected": v["detected"],
                              "sysid": getattr(links.get(vehicle_id), "sysid", None),
                              "autopilot": getattr(links.get(vehicle_id), "autopilot", None)}
                             for vehicle_id, v in zip(self.vehicles, vehicles)],
                "counters": counters,
                "last_track_stamp_ns": max((t["stamp_ns"] for t in tracks), default=None),
                "errors": errors,
                "rmse_m": next(iter(errors.values()))["rmse_m"] if len(errors) == 1 else None,
            }
        if extra:
            summary.update(extra)
        return document, summary

    def _forget_stale_tracks(self) -> int:
        """The oldest stamp of a track still on the map (:data:`TRACK_STALE_STEPS` before the newest stamp
        seen); the targets known by an older track alone (no truth) are dropped, since the tracker
        deleted them and their trails would otherwise be kept for ever (the caller holds the lock)."""
        fresh_ns = (self.newest_ns or 0) - self.track_stale_ns
        for target_id in [target_id for target_id, t in self.targets.items()
                          if t.truth is None and t.track is not None and t.track.stamp_ns < fresh_ns]:
            del self.targets[target_id]
        return fresh_ns

    @staticmethod
    def _track(track: TrackEstimate, trail: Trail) -> dict:
        n = len(track.state)
        cov = np.asarray(track.covariance, dtype=np.float64).reshape(n, n)
        return {
            "target_id": track.target_id, "seq": track.seq, "stamp_ns": track.stamp_ns, "model": track.model,
            "x": _r(track.state[0]), "y": _r(track.state[1]),
            "vx": round(track.state[2], 2) if n > 2 else None, "vy": round(track.state[3], 2) if n > 3 else None,
            "ellipse": ellipse(cov[:2, :2]),
            "cov_xy": [[round(float(cov[0, 0]), 3), round(float(cov[0, 1]), 3)],
                       [round(float(cov[1, 0]), 3), round(float(cov[1, 1]), 3)]],
            "prediction": [{"stamp_ns": p.stamp_ns, "x": _r(p.position_enu_m[0]), "y": _r(p.position_enu_m[1]),
                            "ellipse": ellipse(p.position_cov_m2)} for p in track.prediction],
            "contributing": list(track.contributing_vehicles),
            "trail": trail.encoded(),
        }


def _xyz(values: Iterable[float]) -> tuple[float, float, float]:
    """Three coordinates as Python floats."""
    x, y, z = (float(v) for v in values)
    return x, y, z
