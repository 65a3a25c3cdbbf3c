"""What a vehicle process declares on Zenoh, and how it takes it down: shared by ``run`` and ``payload``.

Per vehicle a ``SensorReport`` publisher on ``<prefix>/vehicle/<id>/report``, a
``NavReport`` publisher on ``<prefix>/vehicle/<id>/nav`` and a ``VehicleScenario``
publisher on ``<prefix>/vehicle/<id>/scenario`` (all BLOCK, as
:func:`gcs.adapters.zenoh_session.declare_publisher` makes them), optionally the
target's ``TargetTruth`` on ``<prefix>/sim/truth/<target>``; the liveliness tokens
``<prefix>/vehicle/<id>/alive`` are the caller's. A :class:`ScenarioAnnouncer` says
when each vehicle announces its scenario: with its first report, then about once a
second of its own time, so that a ground station or recorder that joins later hears
it within a second.
"""

from __future__ import annotations

from collections.abc import Iterable

import zenoh

from gcs.adapters.zenoh_session import declare_publisher
from gcs.config import Scenario
from gcs.config.fingerprint import scenario_fingerprint
from protocols.keys import nav_key, report_key, scenario_key, truth_key
from protocols.messages import NavReport, SensorReport, TargetTruth, VehicleScenario

__all__ = ["ANNOUNCE_EVERY_NS", "ScenarioAnnouncer", "declare_vehicle_publishers", "close_zenoh"]

ANNOUNCE_EVERY_NS = 1_000_000_000
"""A vehicle announces its scenario again with its first report at least this long (its stamps) after the last."""


class ScenarioAnnouncer:
    """Each vehicle's :class:`~protocols.messages.VehicleScenario`, when one is due (see the module docstring)."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario, self.fingerprint = scenario.name, scenario_fingerprint(scenario)
        self._last_ns: dict[str, int] = {}

    def due(self, vehicle_id: str, stamp_ns: int) -> VehicleScenario | None:
        """The announcement to publish before this vehicle's report stamped ``stamp_ns``, or None."""
        last = self._last_ns.get(vehicle_id)
        if last is not None and last <= stamp_ns < last + ANNOUNCE_EVERY_NS:
            return None
        self._last_ns[vehicle_id] = stamp_ns
        return VehicleScenario(vehicle_id=vehicle_id, stamp_ns=stamp_ns, scenario=self.scenario,
                               fingerprint=self.fingerprint)


def declare_vehicle_publishers(session: zenoh.Session, vehicle_ids: Iterable[str], prefix: str,
                               target_ids: Iterable[str] = ()) -> dict[tuple[str, str], zenoh.Publisher]:
    """The publishers by ``(vehicle id, "report" | "nav" | "scenario")``, and ``(target id, "truth")`` for each
    of ``target_ids`` (``<prefix>/truth/<target id>``)."""
    publishers = {}
    for vehicle_id in vehicle_ids:
        publishers[(vehicle_id, "report")] = declare_publisher(session, report_key(vehicle_id, prefix), SensorReport)
        publishers[(vehicle_id, "nav")] = declare_publisher(session, nav_key(vehicle_id, prefix), NavReport)
        publishers[(vehicle_id, "scenario")] = declare_publisher(session, scenario_key(vehicle_id, prefix),
                                                                 VehicleScenario)
    for target_id in target_ids:
        publishers[(target_id, "truth")] = declare_publisher(session, truth_key(target_id, prefix), TargetTruth)
    return publishers


def close_zenoh(tokens: Iterable, publishers: dict, session: zenoh.Session | None) -> None:
    """Withdraw the liveliness tokens, undeclare the publishers (the dict is emptied), close the session."""
    for token in tokens:
        token.undeclare()
    for publisher in publishers.values():
        publisher.undeclare()
    publishers.clear()
    if session is not None:
        session.close()
