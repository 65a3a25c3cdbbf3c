"""Which scenario a vehicle flies: :class:`VehicleScenario`, on ``<prefix>/vehicle/<id>/scenario``.

A simulated vehicle (``sim-vehicles run``) or a payload bridge (``sim-vehicles payload``) flies
against a scenario: its city, its target, its roster. It announces which one, so that a ground
station running another can say so (the daemon warns once per differing scenario), and a
recording remembers it (``gcs replay`` uses it). The announcement is a message of its own, on a
key of its own: a peer that does not know it never subscribes to it, and every other message
stays as it was.

The scenario is named (``scenario``, the scenario's ``name``) and fingerprinted
(``fingerprint``: lower-case hex of a hash of the scenario's settings, every default filled
in, :func:`gcs.config.fingerprint.scenario_fingerprint`), so that two files with one name but
other settings are told apart. Frames, units and validation are as in :mod:`protocols.messages`,
which re-exports this type.
"""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from protocols.base import Message
from protocols.fields import Ident, StampNs

__all__ = ["FINGERPRINT_PATTERN", "VehicleScenario"]

FINGERPRINT_PATTERN = r"^[0-9a-f]{8,64}$(?!\n)"
"""A scenario fingerprint: 8 to 64 lower-case hex digits."""


class VehicleScenario(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The scenario a vehicle flies, announced once a second of its own time.

    Attributes
    ----------
    vehicle_id : str
        The announcing vehicle (its key's id).
    stamp_ns : int
        The vehicle's time of the announcement (simulation time for a simulated vehicle).
    scenario : str
        The scenario's name.
    fingerprint : str
        Lower-case hex of the hash of the scenario's settings (8-64 digits).
    """

    vehicle_id: Ident
    stamp_ns: StampNs
    scenario: Ident
    fingerprint: Annotated[str, Meta(pattern=FINGERPRINT_PATTERN, description="hex digest of the settings")]
