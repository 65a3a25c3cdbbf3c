"""The base of every wire message.

Each message type has a class-level ``VERSION`` (a ``ClassVar``, ignored by msgspec); it
travels in the Zenoh encoding ``application/json;gcs.<TypeName>/<VERSION>``
(:mod:`protocols.codec`).
"""

from __future__ import annotations

from typing import ClassVar

import msgspec

__all__ = ["Message"]


class Message(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every wire message; ``VERSION`` is the wire version of the type."""

    VERSION: ClassVar[int] = 1
