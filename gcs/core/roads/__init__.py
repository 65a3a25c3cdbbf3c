"""Road networks and trackers that keep a ground target on them (docs/road_tracking.md).

The graph:

* :class:`RoadGraph` (nodes, directed edges, successors, branch probabilities) --
  :mod:`gcs.core.roads.graph`; nearest-edge queries -- :mod:`gcs.core.roads.index`;
  driving a distance through junctions -- :mod:`gcs.core.roads.walk`;
* :func:`roads_from_street_grid`, :func:`roads_from_geojson` -- :mod:`gcs.core.roads.sources`.

The trackers (both subclass :class:`RoadMotion`, the shared road and off-road motion; same methods:
``start``, ``predict``, ``update``, ``step``, ``horizon``, ``log_likelihood``):

* :class:`RoadParticleFilter` -- :mod:`gcs.core.roads.particle` (particles on the graph);
* :class:`RoadMixtureFilter` -- :mod:`gcs.core.roads.mixture` (Gaussians on road coordinates);
* what a step's sensing says (:class:`Looks`, :func:`table_sees`) -- :mod:`gcs.core.roads.sensing`;
  what they give back (:class:`RoadHorizon`) -- :mod:`gcs.core.roads.outputs`;
* the particle filter as the tracking loop runs it, its draws seeded by each step's stamp
  (:class:`RoadTracking`) -- :mod:`gcs.core.roads.tracking`.
"""

from gcs.core.roads.graph import RoadGraph
from gcs.core.roads.mixture import RoadMixtureEstimate, RoadMixtureFilter
from gcs.core.roads.model import RoadMotion
from gcs.core.roads.outputs import RoadHorizon
from gcs.core.roads.particle import RoadParticleEstimate, RoadParticleFilter
from gcs.core.roads.sensing import Looks, table_sees
from gcs.core.roads.sources import roads_from_geojson, roads_from_street_grid
from gcs.core.roads.tracking import RoadTracking
from gcs.core.roads.walk import walk

__all__ = ["RoadGraph", "RoadMotion", "RoadHorizon", "Looks", "table_sees", "roads_from_street_grid",
           "roads_from_geojson", "walk", "RoadParticleFilter", "RoadParticleEstimate", "RoadMixtureFilter",
           "RoadMixtureEstimate", "RoadTracking"]

