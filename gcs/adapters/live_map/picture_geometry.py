"""The live map's geometry: uncertainty ellipses, the city and airspace as the page draws them, trails, and its JSON.

Metres are rounded to the decimetre (:func:`rounded`): the page needs no more, and the payload stays small.
"""

from __future__ import annotations

import math
from collections import deque

import msgspec
import numpy as np

from gcs.adapters.live_map.road_lines import road_lines
from gcs.config import Scenario
from gcs.core.world import World

__all__ = ["SIGMAS", "TRAIL_POINTS", "TRAIL_STEP_S", "Trail", "ellipse", "encode_json", "rounded", "world_geometry"]

NS_PER_S = 1_000_000_000
TRAIL_POINTS = 600
"""Points kept per trail (ten minutes at one a second; the page fades and drops the older ones, ``docs/live_map.md``)."""
TRAIL_STEP_S = 1.0
"""A trail takes a point at most once per this many seconds of stamp time."""
SIGMAS = 2.0
"""The drawn uncertainty ellipse is the 2-sigma one: Mahalanobis distance 2 about the mean."""


def rounded(value: float) -> float:
    """Metres rounded to the decimetre: the page needs no more, the payload stays small."""
    return round(float(value), 1)


def ellipse(cov_xy: np.ndarray | tuple[float, ...], sigmas: float = SIGMAS) -> dict:
    """The ``sigmas``-sigma ellipse of a 2x2 position covariance.

    For ``P = [[a, b], [b, c]]`` the eigenvalues are
    ``l_{1,2} = (a + c) / 2 +- sqrt(((a - c) / 2)^2 + b^2)`` (``l_1 >= l_2``) and the
    major axis makes the angle ``theta = atan2(2b, a - c) / 2`` with east
    (counter-clockwise, ENU). The points at Mahalanobis distance ``sigmas`` form
    the ellipse with semi-axes ``sigmas * sqrt(l_1)`` along ``theta`` and
    ``sigmas * sqrt(l_2)`` across it.

    Parameters
    ----------
    cov_xy : array_like, shape (2, 2) or (4,) row-major
        Covariance of (x, y), m^2.
    sigmas : float

    Returns
    -------
    dict
        ``rx`` (major semi-axis, m), ``ry`` (minor, m), ``angle_rad`` (of the major axis).
    """
    a, b, b2, c = (float(v) for v in np.asarray(cov_xy, dtype=np.float64).ravel())
    b = 0.5 * (b + b2)
    mid, half = 0.5 * (a + c), math.hypot(0.5 * (a - c), b)
    major, minor = max(mid + half, 0.0), max(mid - half, 0.0)
    return {"rx": rounded(sigmas * math.sqrt(major)), "ry": rounded(sigmas * math.sqrt(minor)),
            "angle_rad": round(0.5 * math.atan2(2.0 * b, a - c), 4)}


def world_geometry(scenario: Scenario, world: World) -> dict:
    """The static part of the page (``/api/world``): the world's extent (``bounds_m``: west, south, east, north),
    buildings, roads (:func:`~gcs.adapters.live_map.road_lines.road_lines`; none without a road graph) and no-fly
    zones (ENU m)."""
    return {
        "scenario": scenario.name,
        "origin": {"lat_deg": scenario.origin.lat_deg, "lon_deg": scenario.origin.lon_deg,
                   "height_m": scenario.origin.height_m},
        "size_m": [float(world.size_m[0]), float(world.size_m[1])],
        "bounds_m": [rounded(v) for v in world.bounds_m],
        "buildings": [{"footprint": [[rounded(x), rounded(y)] for x, y in footprint], "height_m": rounded(height)}
                      for footprint, height in zip(world.buildings.footprints, world.buildings.heights)],
        "roads": [] if world.roads is None else road_lines(world.roads),
        "no_fly": [{"name": name, "polygon": [[rounded(x), rounded(y)] for x, y in polygon], "floor_m": float(floor),
                    "ceiling_m": float(ceiling)}
                   for name, polygon, floor, ceiling in zip(world.airspace.names, world.airspace.polygons,
                                                            world.airspace.floors_m, world.airspace.ceilings_m)],
        "vehicles": [{"id": v.id, "start": [rounded(v.start_enu_m[0]), rounded(v.start_enu_m[1])]} for v in scenario.vehicles],
        "target_id": scenario.target.id,
        "step_s": scenario.time.step_s,
    }


class Trail:
    """The last :data:`TRAIL_POINTS` positions, at most one per :data:`TRAIL_STEP_S` of stamp time, each
    ``[x, y, t]`` with ``t`` its stamp in whole seconds from the picture's ``trail_epoch_ns``: the page fades a
    trail by age in bands of 3 s or more, and a decimal more would make a snapshot a tenth larger.

    A trail changes once a second at most but is sent five times a second: each
    point is kept as its JSON text, and the trail's JSON array (:meth:`encoded`)
    is joined from them when it has changed (600 points: tens of microseconds,
    where encoding the floats again takes a fifth of a millisecond).
    """

    def __init__(self) -> None:
        self.points: deque[bytes] = deque(maxlen=TRAIL_POINTS)
        self.last_ns: int | None = None
        self._encoded: msgspec.Raw | None = None

    def due(self, stamp_ns: int) -> bool:
        """Whether a position at ``stamp_ns`` would be taken."""
        return self.last_ns is None or stamp_ns - self.last_ns >= TRAIL_STEP_S * NS_PER_S or stamp_ns < self.last_ns

    def add(self, stamp_ns: int, x: float, y: float, epoch_ns: int) -> None:
        if self.due(stamp_ns):
            self.points.append(msgspec.json.encode((rounded(x), rounded(y), round((stamp_ns - epoch_ns) / NS_PER_S))))
            self.last_ns = stamp_ns
            self._encoded = None

    def encoded(self) -> msgspec.Raw:
        """The points as a JSON array of ``[x, y, t]`` (embedded as is by :func:`encode_json`)."""
        if self._encoded is None:
            self._encoded = msgspec.Raw(b"[" + b",".join(self.points) + b"]")
        return self._encoded


def encode_json(document: dict) -> bytes:
    """Compact JSON bytes of a snapshot document (NaN and infinity become null; ``msgspec.Raw`` as it is)."""
    return msgspec.json.encode(document)
