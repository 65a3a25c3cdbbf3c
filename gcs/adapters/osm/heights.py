"""Roof heights of OpenStreetMap buildings, from their tags.

A building's roof height ``h`` (metres above the ground), first rule that applies:

1. ``height`` (OSM key ``height``: the building's full height, roof included):
   metres by default, ``"12"``, ``"12.5"``, ``"12 m"``; feet when marked,
   ``"40 ft"``, ``"40'"``, ``"40'6\\""`` (x 0.3048 m). Anything else (another unit,
   a range, text) is not understood and the next rule applies;
2. ``building:levels`` (storeys above the ground, may be fractional, ``"2.5"``):
   ``h = levels x`` :data:`METRES_PER_LEVEL`;
3. neither: ``h =`` the default height (:data:`DEFAULT_HEIGHT_M`, or the importer's
   ``--default-height``).

Heights outside ``(0,`` :data:`MAX_HEIGHT_M` ``]`` and level counts outside
``(0, 200]`` count as not given. ``roof:levels``, ``min_height`` and the
``building:part`` objects that may carry a taller part's height are not read: a
building is one prism from the ground to ``h``.

Why these numbers (docs/osm.md gives the figures):

* :data:`METRES_PER_LEVEL` = 3 m: a storey of a residential or office building,
  floor to floor, is about 3 m; Mapbox's vector tiles turn ``building:levels``
  into a height with the same 3 m a level.
* :data:`DEFAULT_HEIGHT_M` = 15 m: the median roof height of the tagged buildings
  (``height``, or ``building:levels`` x 3 m) in the Helsinki extract that the
  shipped scenario is built from: 154 of its 446 buildings are tagged, median
  15 m (5 storeys), quartiles 6 and 18 m. The median is robust to the few towers
  and to the one-storey kiosks and sheds, and an untagged city-centre building is
  more likely a block of a few storeys than either. For another place, pass
  ``--default-height`` from its own figures (the importer prints the median of
  the tagged heights it found).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

__all__ = ["METRES_PER_LEVEL", "DEFAULT_HEIGHT_M", "MAX_HEIGHT_M", "HEIGHT_SOURCES", "parse_height", "parse_levels",
           "building_height"]

METRES_PER_LEVEL = 3.0
"""Metres of height per ``building:levels`` storey."""
DEFAULT_HEIGHT_M = 15.0
"""Roof height of a building with neither ``height`` nor ``building:levels``, metres (module docstring)."""
MAX_HEIGHT_M = 1000.0
"""Taller than this is a mistake in the data (the tallest building is 828 m)."""
FEET = 0.3048
HEIGHT_SOURCES = ("height", "building:levels", "default")
"""Where a building's height came from, in the order the rules are tried."""

_NUMBER = r"(\d+(?:\.\d*)?|\.\d+)"
_METRES = re.compile(rf"^{_NUMBER}\s*(?:m|metres|meters)?$")
_FEET = re.compile(rf"^{_NUMBER}\s*(?:ft|feet|')(?:\s*{_NUMBER}\s*(?:\"|in))?$")


def parse_height(text: str | None) -> float | None:
    """A ``height`` tag in metres (module docstring), or None when it is missing or not understood."""
    if text is None:
        return None
    value = text.strip().lower()
    metres = _METRES.match(value)
    if metres:
        height = float(metres.group(1))
    else:
        feet = _FEET.match(value)
        if not feet:
            return None
        height = (float(feet.group(1)) + float(feet.group(2) or 0.0) / 12.0) * FEET
    return height if 0.0 < height <= MAX_HEIGHT_M else None


def parse_levels(text: str | None) -> float | None:
    """A ``building:levels`` tag as a number of storeys, or None when it is missing or not a count in (0, 200]."""
    if text is None:
        return None
    try:
        levels = float(text.strip())
    except ValueError:
        return None
    return levels if math.isfinite(levels) and 0.0 < levels <= 200.0 else None


def building_height(tags: Mapping[str, str], default_height_m: float = DEFAULT_HEIGHT_M) -> tuple[float, str]:
    """``(h, source)``: the roof height in metres and the rule that gave it (one of :data:`HEIGHT_SOURCES`)."""
    height = parse_height(tags.get("height"))
    if height is not None:
        return height, "height"
    levels = parse_levels(tags.get("building:levels"))
    if levels is not None:
        return levels * METRES_PER_LEVEL, "building:levels"
    return float(default_height_m), "default"
