"""The particle cloud of :mod:`gcs.core.roads.particle` and the small operations on it.

* :class:`RoadParticles`: per particle the edge, arc length and speed (on the
  road), the plane position and velocity (off it), the mode and the log-weight;
* :func:`aligned`: a point snapped to a two-way segment put on the directed edge
  its velocity points along;
* :func:`systematic`: systematic resampling (Kitagawa 1996; Arulampalam,
  Maskell, Gordon and Clapp 2002, algorithm 2);
* :func:`invert_detections`: the ground point of each range detection (eq. 4
  inverted), averaged: where to draw a lost cloud again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.models.sensor import AZIMUTH, ELEVATION, RANGE
from gcs.core.roads.graph import RoadGraph
from gcs.core.roads.sensing import DetectionGroup

__all__ = ["RoadParticles", "aligned", "systematic", "invert_detections"]


@dataclass(frozen=True, eq=False)
class RoadParticles:
    """P particles: ``edge``, ``s``, ``speed`` (used on the road), ``on_road``, ``xy`` (P, 2), ``vxy`` (P, 2) (the
    position and velocity of every particle, the road's for those on it) and ``log_weight`` (normalised)."""

    edge: NDArray[np.intp]
    s: NDArray[np.float64]
    speed: NDArray[np.float64]
    on_road: NDArray[np.bool_]
    xy: NDArray[np.float64]
    vxy: NDArray[np.float64]
    log_weight: NDArray[np.float64]

    @classmethod
    def build(cls, graph: RoadGraph, edge: NDArray[np.intp], s: NDArray[np.float64], speed: NDArray[np.float64],
              on_road: NDArray[np.bool_], xy: ArrayLike, vxy: ArrayLike, log_weight: NDArray[np.float64]
              ) -> RoadParticles:
        """The cloud, with the position and velocity of every road particle taken from its edge."""
        xy, vxy = np.array(xy, dtype=np.float64), np.array(vxy, dtype=np.float64)
        road = np.flatnonzero(on_road)
        xy[road] = graph.position(edge[road], s[road])
        vxy[road] = speed[road, None] * graph.direction[edge[road]]
        return cls(edge, s, speed, on_road, xy, vxy, log_weight)

    @property
    def weights(self) -> NDArray[np.float64]:
        """Normalised weights (P,)."""
        return np.exp(self.log_weight)

    @property
    def states(self) -> NDArray[np.float64]:
        """``[x, y, vx, vy]`` of every particle (P, 4)."""
        return np.concatenate([self.xy, self.vxy], axis=1)

    def subset(self, pick: NDArray[np.intp]) -> RoadParticles:
        """The particles ``pick`` (with repeats), equally weighted."""
        n = len(pick)
        return RoadParticles(self.edge[pick], self.s[pick], self.speed[pick], self.on_road[pick], self.xy[pick],
                             self.vxy[pick], np.full(n, -np.log(n)))

    def branch_weights(self) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """The edges that hold road particles and the weight on each (the branches), heaviest first."""
        road = self.on_road
        edges, inverse = np.unique(self.edge[road], return_inverse=True)
        mass = np.bincount(inverse, weights=self.weights[road], minlength=len(edges)).astype(np.float64)
        order = np.argsort(-mass)
        return edges[order], mass[order]


def aligned(graph: RoadGraph, edge: NDArray[np.intp], s: NDArray[np.float64], velocity: NDArray[np.float64]
            ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """Points on edges put on the directed edge of the same segment their velocity (n, 2) points along:
    ``(edge, s, speed)`` with ``speed = |v . d_e|``."""
    along = np.einsum("na,na->n", velocity, graph.direction[edge])
    twin = graph.reverse[edge]
    flip = (along < 0.0) & (twin >= 0)
    new_edge = np.where(flip, twin, edge)
    new_s = np.where(flip, graph.length[edge] - s, s)
    return new_edge, new_s, np.abs(along)


def systematic(weights: NDArray[np.float64], rng: np.random.Generator, count: int | None = None) -> NDArray[np.intp]:
    """``count`` (default: as many as weights) indices drawn by systematic resampling."""
    n = len(weights) if count is None else int(count)
    cumulative = np.cumsum(weights)
    cumulative /= cumulative[-1]
    positions = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cumulative, positions), len(weights) - 1)


def invert_detections(groups: Sequence[DetectionGroup]) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The mean ground point (2,) of every range detection inverted, and a covariance (2, 2) for it; None
    without range. A detection ``(rho, phi[, theta])`` from ``p`` is at ``p + g (cos phi, sin phi)`` with ground
    distance ``g = rho cos theta`` (or ``sqrt(rho^2 - dz^2)`` without elevation)."""
    points, variances = [], []
    for sensor, z, xyz, _ in groups:
        if RANGE not in sensor.components:
            continue
        z = np.asarray(z, dtype=np.float64).reshape(-1, sensor.dim)
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        rho = z[:, sensor.components.index(RANGE)]
        phi = z[:, sensor.components.index(AZIMUTH)]
        if ELEVATION in sensor.components:
            ground = rho * np.cos(z[:, sensor.components.index(ELEVATION)])
        else:
            ground = np.sqrt(np.maximum(rho**2 - (xyz[:, 2] - sensor.target_height_m) ** 2, 0.0))
        points.append(xyz[:, :2] + ground[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1))
        std = dict(zip(sensor.components, sensor.std))
        variances.append(std[RANGE] ** 2 + (ground * std[AZIMUTH]) ** 2)
    if not points:
        return None
    stacked, var = np.concatenate(points), np.concatenate(variances)
    return stacked.mean(axis=0), (var.mean() + 25.0) * np.eye(2)
