"""The parameters both road trackers share: the graph, how a car drives it, and how it leaves it.

* along the road the speed is a white-noise acceleration of density ``speed_psd_m2_s3``
  (the particle filter caps it at ``max_speed_mps``);
* at a junction the car goes straight on with ``1 - turn_probability`` and the
  turns share ``turn_probability`` (:meth:`RoadGraph.branch_probabilities`);
* it leaves the road at the rate ``leave_rate_per_s`` (a car park, a square) and,
  within ``rejoin_m`` of a road, comes back at ``rejoin_rate_per_s``; off the road it
  moves as wang2012 eq. (2)'s constant velocity of density ``off_road_psd_m2_s3``;
* a hypothesis on the road stands for ``spread_m`` of road either side (the car's
  place across the road, the graph's drawing error), added to the measurement noise;
* a new track puts ``initial_off_road`` of its weight off the road.

Defaults are for cars in a city at 5-20 m/s, not tuned per scenario.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.roads.graph import RoadGraph

__all__ = ["RoadMotion"]


@dataclass(frozen=True)
class RoadMotion:
    """The road motion and mode-switch parameters (module docstring); the trackers subclass it."""

    graph: RoadGraph
    speed_psd_m2_s3: float = 1.0
    max_speed_mps: float = 40.0
    turn_probability: float = 0.5
    leave_rate_per_s: float = 0.01
    rejoin_rate_per_s: float = 0.2
    rejoin_m: float = 25.0
    off_road_psd_m2_s3: float = 2.0
    spread_m: float = 3.0
    initial_off_road: float = 0.05

    def __post_init__(self) -> None:
        if not isinstance(self.graph, RoadGraph):
            raise TypeError(f"graph must be a RoadGraph, got {type(self.graph).__name__}")
        for name in ("speed_psd_m2_s3", "leave_rate_per_s", "rejoin_rate_per_s", "rejoin_m", "off_road_psd_m2_s3",
                     "spread_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        if not 0.0 <= self.initial_off_road <= 1.0:
            raise ValueError(f"initial_off_road must be in [0, 1], got {self.initial_off_road}")
        self.graph.branch_probabilities(self.turn_probability)  # checks turn_probability

    @property
    def table(self) -> NDArray[np.float64]:
        """The branch probabilities ``T (E, K)`` (:meth:`RoadGraph.branch_probabilities`)."""
        return self.graph.branch_probabilities(self.turn_probability)
