"""What a vehicle process declares on Zenoh, and how it takes it down: shared by ``run`` and ``payload``.

Per vehicle a ``SensorReport`` publisher on ``<prefix>/vehicle/<id>/report`` and a
``NavReport`` publisher on ``<prefix>/vehicle/<id>/nav`` (both BLOCK, as
:func:`gcs.adapters.zenoh_session.declare_publisher` makes them), optionally the
target's ``TargetTruth`` on ``<prefix>/sim/truth/<target>``; the liveliness tokens
``<prefix>/vehicle/<id>/alive`` are the caller's.
"""

from __future__ import annotations

from collections.abc import Iterable

import zenoh

from gcs.adapters.zenoh_session import declare_publisher
from protocols.keys import nav_key, report_key, truth_key
from protocols.messages import NavReport, SensorReport, TargetTruth

__all__ = ["declare_vehicle_publishers", "close_zenoh"]


def declare_vehicle_publishers(session: zenoh.Session, vehicle_ids: Iterable[str], prefix: str,
                               target_ids: Iterable[str] = ()) -> dict[tuple[str, str], zenoh.Publisher]:
    """The publishers by ``(vehicle id, "report" | "nav")``, and ``(target id, "truth")`` for each of
    ``target_ids`` (``<prefix>/truth/<target id>``)."""
    publishers = {}
    for vehicle_id in vehicle_ids:
        publishers[(vehicle_id, "report")] = declare_publisher(session, report_key(vehicle_id, prefix), SensorReport)
        publishers[(vehicle_id, "nav")] = declare_publisher(session, nav_key(vehicle_id, prefix), NavReport)
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
