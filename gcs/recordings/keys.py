"""The keys of a recording: which kind of the key space each is, under whatever prefix it was recorded."""

from __future__ import annotations

import functools

from protocols.errors import ProtocolError
from protocols.keys import parse_key

__all__ = ["INPUT_KINDS", "VEHICLE_KINDS", "key_kind", "prefix_of"]

INPUT_KINDS = ("report", "nav", "truth", "scenario", "alive")
"""Key kinds that are inputs of the daemon (the rest, tracks, plans and status, are its outputs)."""
VEHICLE_KINDS = ("report", "nav", "scenario", "alive")
"""Key kinds a vehicle publishes (the key names the vehicle)."""


def prefix_of(key: str) -> str | None:
    """The prefix a key of the key space is under (``gcs`` for ``gcs/vehicle/uav1/report``)."""
    for marker in ("/vehicle/", "/track/", "/plan/", "/daemon/", "/sim/", "/federation/"):
        if marker in key:
            return key[: key.index(marker)]
    return None


@functools.lru_cache(maxsize=4096)
def key_kind(key: str) -> tuple[str | None, str | None]:
    """Kind and id of a key of the key space under any prefix; (None, None) for other keys."""
    prefix = prefix_of(key)
    if prefix is None:
        return None, None
    try:
        parsed = parse_key(key, prefix)
    except ProtocolError:
        return None, None
    return parsed.kind, parsed.ident
