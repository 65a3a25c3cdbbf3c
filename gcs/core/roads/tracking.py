"""The road tracker as the tracking loop runs it: a step's detections and looks in, the track out, and the
k+1..k+n prediction the planner plans on (docs/road_tracking.md).

:class:`RoadTracking` holds the particle filter (:class:`~gcs.core.roads.particle.RoadParticleFilter`),
how the world answers "does vehicle ``v`` see ground point ``x``" (``sees``, for negative
information), the detection probability those looks assume, and a seed.

**Randomness from the inputs.** The filter draws random numbers (motion, branching, resampling).
A step's draws come from ``numpy.random.default_rng([seed, purpose, stamp_ns])``: the same
seed, estimate and detections give the same track bit for bit, whoever fuses them and in
whatever process (the daemon live, ``gcs replay --process``, a benchmark), and one step's
draws do not depend on how many were drawn before. ``purpose`` keeps the update's and the
horizon's streams apart (:data:`FUSE_STREAM`, :data:`HORIZON_STREAM`).

**The state** is the estimate itself: a :class:`~gcs.core.roads.particle.RoadParticleEstimate`,
the moment-matched ``cv2d`` Gaussian (mean and covariance of the mixture: the minimum
mean-square-error point) carrying its particles, so everything that takes a Gaussian
estimate takes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.roads.outputs import RoadHorizon
from gcs.core.roads.particle import RoadParticleEstimate, RoadParticleFilter
from gcs.core.roads.sensing import DetectionGroup, Looks, Sees

__all__ = ["RoadTracking", "FUSE_STREAM", "HORIZON_STREAM"]

FUSE_STREAM = 0
"""``purpose`` of a step's update draws."""
HORIZON_STREAM = 1
"""``purpose`` of a step's k+1..k+n prediction draws."""


@dataclass(frozen=True)
class RoadTracking:
    """The road tracker of the loop (module docstring); holds parameters, never the estimate.

    Attributes
    ----------
    filter : RoadParticleFilter
    sees : callable or None
        ``sees(points (P, 2), vehicle_xyz (V, 3)) -> (V, P)``: in range and in sight
        (:func:`~gcs.core.roads.sensing.table_sees`); None leaves negative information out.
    detection_probability : float
        ``P_D`` of the looks (:class:`~gcs.core.roads.sensing.Looks`); 0 leaves negative information out.
    seed : int
        Seeds every step's generator, with the step's stamp.
    horizon_samples : int
        Particles driven on through the graph for the k+1..k+n prediction.
    """

    filter: RoadParticleFilter
    sees: Sees | None = None
    detection_probability: float = 0.9
    seed: int = 0
    horizon_samples: int = 64

    def __post_init__(self) -> None:
        if not 0.0 <= self.detection_probability < 1.0:
            raise ValueError(f"detection_probability must be in [0, 1), got {self.detection_probability!r}")
        if self.seed < 0 or self.horizon_samples < 1:
            raise ValueError(f"seed must be >= 0 and horizon_samples >= 1, got {self.seed}, {self.horizon_samples}")

    def generator(self, stamp_ns: int, purpose: int) -> np.random.Generator:
        """The draws of the step at ``stamp_ns`` for ``purpose`` (module docstring)."""
        return np.random.default_rng([self.seed, purpose, int(stamp_ns)])

    def looks(self, vehicle_xyz: NDArray[np.float64] | None, detected: NDArray[np.bool_] | None) -> Looks | None:
        """What the vehicles that sensed this step say (positions (V, 3), which detected (V,)); None without
        negative information."""
        if self.sees is None or self.detection_probability == 0.0 or vehicle_xyz is None or detected is None:
            return None
        return Looks(vehicle_xyz, detected, self.sees, self.detection_probability)

    def start(self, initial: GaussianEstimate, groups: Sequence[DetectionGroup], looks: Looks | None
              ) -> RoadParticleEstimate:
        """A new track: particles drawn about ``initial`` (a detection inverted, an ML fix) and put on the roads,
        then weighed by the step's detections and looks, at ``initial.stamp_ns``."""
        rng = self.generator(initial.stamp_ns, FUSE_STREAM)
        return self.filter.update(self.filter.start(initial, rng), groups, looks, rng)

    def step(self, estimate: RoadParticleEstimate, stamp_ns: int, groups: Sequence[DetectionGroup],
             looks: Looks | None) -> RoadParticleEstimate:
        """The track moved to ``stamp_ns`` and weighed by the step's detections and looks."""
        return self.filter.step(estimate, stamp_ns, groups, looks, self.generator(stamp_ns, FUSE_STREAM))

    def horizon(self, estimate: RoadParticleEstimate, step_s: float, steps: int) -> RoadHorizon:
        """k+1..k+``steps``: :attr:`horizon_samples` particles driven on, branching; samples (T, S, 2), weights
        (T, S), and the moment-matched Gaussians."""
        return self.filter.horizon(estimate, step_s, steps, self.generator(estimate.stamp_ns, HORIZON_STREAM),
                                   self.horizon_samples)
