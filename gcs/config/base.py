"""What every scenario table is made of: the frozen base Struct and the unit-carrying field types."""

from __future__ import annotations

import math
from typing import Annotated

import msgspec

__all__ = ["Config", "Identifier", "Metres", "NonNegative", "Point2", "Positive", "Radians"]

Positive = Annotated[float, msgspec.Meta(gt=0.0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0)]
Metres = Annotated[float, msgspec.Meta(ge=-1e7, le=1e7)]
Radians = Annotated[float, msgspec.Meta(ge=-2 * math.pi, le=2 * math.pi)]
Identifier = Annotated[str, msgspec.Meta(pattern=r"^[A-Za-z0-9_-]{1,64}$")]
Point2 = tuple[Metres, Metres]


class Config(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every configuration table: frozen, unknown keys rejected."""
