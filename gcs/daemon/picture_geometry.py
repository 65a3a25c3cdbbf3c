"""The live map's geometry: uncertainty ellipses, the city and airspace as the page draws them, and its JSON.

Metres are rounded to the decimetre (:func:`rounded`): the page needs no more, and the payload stays small.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np

from gcs.config import Scenario
from gcs.core.world import World

__all__ = ["SIGMAS", "ellipse", "encode_json", "rounded", "world_geometry"]

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
    """The static part of the page (``/api/world``): the city rectangle, buildings and no-fly zones (ENU m)."""
    return {
        "scenario": scenario.name,
        "origin": {"lat_deg": scenario.origin.lat_deg, "lon_deg": scenario.origin.lon_deg,
                   "height_m": scenario.origin.height_m},
        "size_m": [float(world.size_m[0]), float(world.size_m[1])],
        "buildings": [{"footprint": [[rounded(x), rounded(y)] for x, y in footprint], "height_m": rounded(height)}
                      for footprint, height in zip(world.buildings.footprints, world.buildings.heights)],
        "no_fly": [{"name": name, "polygon": [[rounded(x), rounded(y)] for x, y in polygon], "floor_m": float(floor),
                    "ceiling_m": float(ceiling)}
                   for name, polygon, floor, ceiling in zip(world.airspace.names, world.airspace.polygons,
                                                            world.airspace.floors_m, world.airspace.ceilings_m)],
        "vehicles": [{"id": v.id, "start": [rounded(v.start_enu_m[0]), rounded(v.start_enu_m[1])]} for v in scenario.vehicles],
        "target_id": scenario.target.id,
        "step_s": scenario.time.step_s,
    }


def encode_json(document: dict) -> bytes:
    """Compact JSON bytes of a snapshot document (NaN and infinity become null; ``msgspec.Raw`` as it is)."""
    return msgspec.json.encode(document)
