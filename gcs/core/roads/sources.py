"""Road graphs of a generated city's street grid and of GeoJSON LineStrings.

* :func:`roads_from_street_grid`: the centre lines of a
  :class:`gcs.core.world.StreetGrid` (every north-south street at ``xs``, every
  east-west street at ``ys``, the city's edges included), cut at every crossing:
  the streets :class:`sim_vehicles.truth.target.StreetTarget` drives.
* :func:`roads_from_geojson`: every ``LineString`` or ``MultiLineString`` feature
  of an already-parsed FeatureCollection (the file is read by
  ``gcs.config.world``), each consecutive vertex pair one segment. Roads meet
  where their vertices agree to ``merge_m``. A feature whose
  ``properties[oneway_property]`` is true (``true``, ``"yes"``, ``"1"``, ``1``) is
  drivable in its drawing order only; ``"-1"`` reverses it (OpenStreetMap's tag).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.roads.graph import RoadGraph
from gcs.core.world._geojson import features_with_parts
from gcs.core.world.buildings import StreetGrid

__all__ = ["roads_from_street_grid", "roads_from_geojson"]

ToEnu = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[ArrayLike, ArrayLike]]
_ONEWAY_TRUE = {"yes", "true", "1"}
_ONEWAY_FALSE = {"no", "false", "0"}


def roads_from_street_grid(grid: StreetGrid) -> RoadGraph:
    """The grid's centre lines, one two-way segment between each pair of neighbouring crossings."""
    xs, ys = np.asarray(grid.xs, dtype=np.float64), np.asarray(grid.ys, dtype=np.float64)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")  # crossing (i, j) at (xs[i], ys[j])
    crossings = np.stack([gx, gy], axis=-1)
    starts = [crossings[:, :-1].reshape(-1, 2), crossings[:-1, :].reshape(-1, 2)]  # north-south, east-west
    ends = [crossings[:, 1:].reshape(-1, 2), crossings[1:, :].reshape(-1, 2)]
    merge = 0.25 * float(min(np.diff(xs).min(initial=np.inf), np.diff(ys).min(initial=np.inf), 4.0))
    return RoadGraph.from_segments(np.concatenate(starts), np.concatenate(ends), merge_m=max(merge, 1e-3))


def roads_from_geojson(obj: Mapping[str, Any], to_enu: ToEnu | None = None, oneway_property: str = "oneway",
                       merge_m: float = 0.5) -> RoadGraph:
    """A road graph from a parsed GeoJSON FeatureCollection of LineStrings (module docstring).

    Parameters
    ----------
    obj : mapping
        The parsed FeatureCollection (``json.load`` output).
    to_enu : callable, optional
        ``to_enu(lon_deg, lat_deg) -> (x, y)`` on arrays; without it coordinates are ENU metres.
    oneway_property : str
        The property that marks one-way roads.
    merge_m : float
        Vertices closer than this are one node, metres.

    Raises
    ------
    ValueError
        Naming the feature index (and the line of a MultiLineString) and the problem.
    """
    starts, ends, oneway = [], [], []
    for where, feature, parts in features_with_parts(obj, "LineString", "MultiLineString", "line", "GeoJSON roads"):
        direction = _oneway(feature, oneway_property, where)
        for label, line in parts:
            points = _line(line, label, to_enu)
            if direction < 0:
                points = points[::-1]
            starts.append(points[:-1])
            ends.append(points[1:])
            oneway.append(np.full(len(points) - 1, direction != 0))
    if not starts:
        raise ValueError("GeoJSON roads: no LineString features")
    return RoadGraph.from_segments(np.concatenate(starts), np.concatenate(ends), np.concatenate(oneway), merge_m)


def _oneway(feature: Mapping[str, Any], key: str, where: str) -> int:
    """1 one-way in drawing order, -1 against it, 0 two-way."""
    properties = feature.get("properties")
    if properties is None:
        return 0
    if not isinstance(properties, Mapping):
        raise ValueError(f"{where}: \"properties\" must be an object")
    value = properties.get(key)
    if value is None or value is False:
        return 0
    if value is True:
        return 1
    text = str(value).strip().lower() if isinstance(value, (str, numbers.Integral)) else None
    if text in _ONEWAY_TRUE:
        return 1
    if text in _ONEWAY_FALSE:
        return 0
    if text == "-1":
        return -1
    raise ValueError(f"{where}: property {key!r} must be true, false, \"yes\", \"no\" or \"-1\", got {value!r}")


def _line(line: Any, where: str, to_enu: ToEnu | None) -> NDArray[np.float64]:
    try:
        points = np.array(line, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: coordinates must be a list of [x, y] number pairs") from None
    if points.ndim != 2 or points.shape[1] < 2:
        raise ValueError(f"{where}: coordinates must be a list of [x, y] number pairs")
    if len(points) < 2:
        raise ValueError(f"{where}: a line needs at least 2 points, got {len(points)}")
    points = points[:, :2]
    if not np.isfinite(points).all():
        raise ValueError(f"{where}: coordinates must be finite")
    if to_enu is not None:
        x, y = to_enu(points[:, 0], points[:, 1])
        points = np.stack([np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)], axis=-1)
    return points
