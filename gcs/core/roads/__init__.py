"""Road networks and trackers that keep a ground target on them (design.md section 8).

* :class:`RoadGraph` (nodes, directed edges, successors, branch probabilities) --
  :mod:`gcs.core.roads.graph`; nearest-edge queries -- :mod:`gcs.core.roads.index`;
  driving a distance through junctions -- :mod:`gcs.core.roads.walk`;
* :func:`roads_from_street_grid`, :func:`roads_from_geojson` -- :mod:`gcs.core.roads.sources`.
"""

from gcs.core.roads.graph import RoadGraph
from gcs.core.roads.sources import roads_from_geojson, roads_from_street_grid
from gcs.core.roads.walk import walk

__all__ = ["RoadGraph", "roads_from_street_grid", "roads_from_geojson", "walk"]
