"""Zenoh key expressions of the ground station's key space.

Key space (``<prefix>`` defaults to ``gcs``)::

    <prefix>/vehicle/<vehicle_id>/report   SensorReport      vehicle -> daemon
    <prefix>/vehicle/<vehicle_id>/nav      NavReport         vehicle -> daemon
    <prefix>/vehicle/<vehicle_id>/alive    liveliness token  (no payload)
    <prefix>/vehicle/<vehicle_id>/scenario VehicleScenario   vehicle -> daemon, recorder
    <prefix>/track/<target_id>             TrackEstimate     daemon, published and queryable
    <prefix>/plan/<vehicle_id>             PlanCommand       daemon
    <prefix>/daemon/status                 DaemonStatus      daemon, published and queryable
    <prefix>/sim/truth/<target_id>         TargetTruth       simulator only (scoring, display)
    <prefix>/federation/<member_id>/tracks MemberTracks      daemon -> the federation's other daemons
    <prefix>/federation/<member_id>/alive  liveliness token  (no payload) while a member runs

A federation of daemons (:mod:`protocols.federation`) shares a prefix of its own for the
``federation`` keys; each daemon keeps its team's vehicles, tracks and plans under the team's prefix.

A prefix is one or more ``/``-separated chunks, each matching ``[A-Za-z0-9_-]+``
(``"replay/run1"`` is valid), so replayed data can run beside live data. Ids match
``[A-Za-z0-9_-]{1,64}``: no ``/``, no wildcard, no ``$``, ``@``, ``?`` or ``#``.
Every invalid id, prefix or key raises :class:`~protocols.errors.ProtocolError`
naming the bad part.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal

from protocols.errors import ProtocolError
from protocols.fields import ID_REGEX
from protocols.messages import (
    DaemonStatus,
    MemberTracks,
    Message,
    NavReport,
    PlanCommand,
    SensorReport,
    TargetTruth,
    TrackEstimate,
    VehicleScenario,
)

__all__ = [
    "DEFAULT_PREFIX",
    "KEY_KINDS",
    "MESSAGE_TYPE_BY_KIND",
    "KeyKind",
    "ParsedKey",
    "alive_key",
    "member_alive_key",
    "member_alive_selector",
    "member_tracks_key",
    "member_tracks_selector",
    "alive_selector",
    "nav_key",
    "navs_selector",
    "parse_key",
    "plan_key",
    "plans_selector",
    "report_key",
    "reports_selector",
    "scenario_key",
    "scenarios_selector",
    "status_key",
    "track_key",
    "tracks_selector",
    "truth_key",
    "truth_selector",
    "validate_id",
    "validate_prefix",
]

DEFAULT_PREFIX = "gcs"

KeyKind = Literal["report", "nav", "alive", "scenario", "track", "plan", "status", "truth", "member",
                  "member_alive"]
KEY_KINDS: tuple[str, ...] = ("report", "nav", "alive", "scenario", "track", "plan", "status", "truth", "member",
                              "member_alive")

#: Message type carried on each kind of key (``alive`` is a liveliness token: no payload).
MESSAGE_TYPE_BY_KIND: Mapping[str, type[Message]] = MappingProxyType(
    {
        "report": SensorReport,
        "nav": NavReport,
        "scenario": VehicleScenario,
        "track": TrackEstimate,
        "plan": PlanCommand,
        "status": DaemonStatus,
        "truth": TargetTruth,
        "member": MemberTracks,
    }
)

_ID_RE = re.compile(ID_REGEX)
_PREFIX_RE = re.compile(r"[A-Za-z0-9_-]+(?:/[A-Za-z0-9_-]+)*")
_VEHICLE_KINDS = {"report", "nav", "alive", "scenario"}


@dataclass(frozen=True)
class ParsedKey:
    """A key expression taken apart.

    Attributes
    ----------
    kind : str
        One of ``"report"``, ``"nav"``, ``"alive"``, ``"scenario"``, ``"track"``, ``"plan"``, ``"status"``,
        ``"truth"``, ``"member"`` (a federation member's tracks), ``"member_alive"`` (its liveliness token).
    ident : str or None
        The vehicle id (report, nav, alive, scenario, plan), the target id (track, truth), the member id
        (member, member_alive), or None (status).
    """

    kind: KeyKind
    ident: str | None


def validate_id(value: object, what: str = "id") -> str:
    """Return ``value`` if it is a valid id chunk, else raise.

    Parameters
    ----------
    value : object
        Candidate id; must be a ``str`` matching ``[A-Za-z0-9_-]{1,64}``.
    what : str
        What the id is (``"vehicle_id"``, ``"target_id"``), for the message.

    Raises
    ------
    ProtocolError
        Naming ``what`` and the offending value.
    """
    if not isinstance(value, str) or _ID_RE.fullmatch(value) is None:
        raise ProtocolError(
            f"invalid {what} {value!r}: must be 1-64 characters from [A-Za-z0-9_-]",
            reason="key",
        )
    return value


def validate_prefix(prefix: object) -> str:
    """Return ``prefix`` if it is ``/``-separated chunks of ``[A-Za-z0-9_-]+``, else raise.

    Raises
    ------
    ProtocolError
        Naming the offending prefix.
    """
    if not isinstance(prefix, str) or _PREFIX_RE.fullmatch(prefix) is None:
        raise ProtocolError(
            f"invalid key prefix {prefix!r}: must be one or more '/'-separated chunks "
            "of [A-Za-z0-9_-] with no leading or trailing '/'",
            reason="key",
        )
    return prefix


def _vehicle_key(vehicle_id: str, leaf: str, prefix: str) -> str:
    return f"{validate_prefix(prefix)}/vehicle/{validate_id(vehicle_id, 'vehicle_id')}/{leaf}"


def report_key(vehicle_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of one vehicle's sensor reports: ``<prefix>/vehicle/<id>/report``."""
    return _vehicle_key(vehicle_id, "report", prefix)


def nav_key(vehicle_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of one vehicle's navigation reports: ``<prefix>/vehicle/<id>/nav``."""
    return _vehicle_key(vehicle_id, "nav", prefix)


def alive_key(vehicle_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of one vehicle's liveliness token: ``<prefix>/vehicle/<id>/alive``."""
    return _vehicle_key(vehicle_id, "alive", prefix)


def scenario_key(vehicle_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of the scenario one vehicle announces: ``<prefix>/vehicle/<id>/scenario``."""
    return _vehicle_key(vehicle_id, "scenario", prefix)


def track_key(target_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of one target's track: ``<prefix>/track/<target_id>``."""
    return f"{validate_prefix(prefix)}/track/{validate_id(target_id, 'target_id')}"


def plan_key(vehicle_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of one vehicle's plan command: ``<prefix>/plan/<vehicle_id>``."""
    return f"{validate_prefix(prefix)}/plan/{validate_id(vehicle_id, 'vehicle_id')}"


def status_key(prefix: str = DEFAULT_PREFIX) -> str:
    """Key of the daemon status: ``<prefix>/daemon/status``."""
    return f"{validate_prefix(prefix)}/daemon/status"


def truth_key(target_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of a simulated target's truth: ``<prefix>/sim/truth/<target_id>``."""
    return f"{validate_prefix(prefix)}/sim/truth/{validate_id(target_id, 'target_id')}"


def member_tracks_key(member_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of a federation member's tracks: ``<prefix>/federation/<member_id>/tracks``."""
    return f"{validate_prefix(prefix)}/federation/{validate_id(member_id, 'member_id')}/tracks"


def member_alive_key(member_id: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Key of a federation member's liveliness token: ``<prefix>/federation/<member_id>/alive``."""
    return f"{validate_prefix(prefix)}/federation/{validate_id(member_id, 'member_id')}/alive"


def member_tracks_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every federation member's tracks: ``<prefix>/federation/*/tracks``."""
    return f"{validate_prefix(prefix)}/federation/*/tracks"


def member_alive_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every federation member's liveliness token: ``<prefix>/federation/*/alive``."""
    return f"{validate_prefix(prefix)}/federation/*/alive"


def truth_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every simulated target's truth: ``<prefix>/sim/truth/*``."""
    return f"{validate_prefix(prefix)}/sim/truth/*"


def reports_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every vehicle's sensor reports: ``<prefix>/vehicle/*/report``."""
    return f"{validate_prefix(prefix)}/vehicle/*/report"


def navs_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every vehicle's navigation reports: ``<prefix>/vehicle/*/nav``."""
    return f"{validate_prefix(prefix)}/vehicle/*/nav"


def alive_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every vehicle's liveliness token: ``<prefix>/vehicle/*/alive``."""
    return f"{validate_prefix(prefix)}/vehicle/*/alive"


def scenarios_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every vehicle's scenario announcement: ``<prefix>/vehicle/*/scenario``."""
    return f"{validate_prefix(prefix)}/vehicle/*/scenario"


def tracks_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every target's track: ``<prefix>/track/*``."""
    return f"{validate_prefix(prefix)}/track/*"


def plans_selector(prefix: str = DEFAULT_PREFIX) -> str:
    """Selector for every vehicle's plan command: ``<prefix>/plan/*``."""
    return f"{validate_prefix(prefix)}/plan/*"


def parse_key(key: str, prefix: str = DEFAULT_PREFIX) -> ParsedKey:
    """Take a concrete key expression of the key space apart.

    Parameters
    ----------
    key : str
        A key as received on a sample (no wildcards).
    prefix : str
        The prefix the key is expected under.

    Returns
    -------
    ParsedKey

    Raises
    ------
    ProtocolError
        If the prefix is invalid, the key is not under it, its shape is not one of
        the key space's, or an id chunk is invalid (the message names which).
    """
    validate_prefix(prefix)
    if not isinstance(key, str):
        raise ProtocolError(f"key must be a str, got {type(key).__name__}", reason="key")
    head = prefix + "/"
    if not key.startswith(head):
        raise ProtocolError(f"key {key!r} is not under prefix {prefix!r}", reason="key")
    parts = key[len(head) :].split("/")
    if len(parts) == 3 and parts[0] == "vehicle" and parts[2] in _VEHICLE_KINDS:
        kind: KeyKind = parts[2]  # type: ignore[assignment]
        return ParsedKey(kind=kind, ident=validate_id(parts[1], "vehicle_id"))
    if len(parts) == 2 and parts[0] == "track":
        return ParsedKey(kind="track", ident=validate_id(parts[1], "target_id"))
    if len(parts) == 2 and parts[0] == "plan":
        return ParsedKey(kind="plan", ident=validate_id(parts[1], "vehicle_id"))
    if parts == ["daemon", "status"]:
        return ParsedKey(kind="status", ident=None)
    if len(parts) == 3 and parts[:2] == ["sim", "truth"]:
        return ParsedKey(kind="truth", ident=validate_id(parts[2], "target_id"))
    if len(parts) == 3 and parts[0] == "federation" and parts[2] in ("tracks", "alive"):
        return ParsedKey(kind="member" if parts[2] == "tracks" else "member_alive",
                         ident=validate_id(parts[1], "member_id"))
    raise ProtocolError(
        f"key {key!r} is not in the key space under prefix {prefix!r} (expected "
        "vehicle/<id>/report|nav|alive|scenario, track/<id>, plan/<id>, daemon/status, sim/truth/<id> "
        "or federation/<id>/tracks|alive)",
        reason="key",
    )
