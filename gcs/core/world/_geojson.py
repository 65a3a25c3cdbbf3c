"""Walking a parsed GeoJSON FeatureCollection: each feature and the parts of its (multi-)geometry, with labels.

Shared by the buildings' footprints (Polygon / MultiPolygon) and the roads
(LineString / MultiLineString): the same checks and the same error labels
(``feature 3``, ``feature 3 polygon 1``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

__all__ = ["features_with_parts"]


def features_with_parts(obj: Any, single: str, multi: str, part_name: str, what: str = "GeoJSON"
                        ) -> Iterator[tuple[str, Mapping[str, Any], list[tuple[str, Any]]]]:
    """``(where, feature, [(label, coordinates), ...])`` for every feature of type ``single`` or ``multi``.

    ValueError naming the feature for anything else: not a FeatureCollection, a
    feature that is not an object, another geometry type.
    """
    if not isinstance(obj, Mapping) or obj.get("type") != "FeatureCollection":
        raise ValueError(f"{what}: expected an object with \"type\": \"FeatureCollection\"")
    features = obj.get("features")
    if not isinstance(features, list):
        raise ValueError(f"{what}: \"features\" must be a list")
    for index, feature in enumerate(features):
        where = f"feature {index}"
        if not isinstance(feature, Mapping):
            raise ValueError(f"{where}: not an object")
        geometry = feature.get("geometry")
        kind = geometry.get("type") if isinstance(geometry, Mapping) else None
        coordinates = geometry.get("coordinates") if isinstance(geometry, Mapping) else None
        if kind == single:
            parts = [(where, coordinates)]
        elif kind == multi and isinstance(coordinates, list):
            parts = [(f"{where} {part_name} {i}", part) for i, part in enumerate(coordinates)]
        else:
            raise ValueError(f"{where}: geometry type {kind!r} is not supported ({single} or {multi})")
        yield where, feature, parts
