"""The particle clouds of many road tracks side by side: T tracks of P particles each, moved and resampled at once.

Track ``t``'s posterior is a cloud of P particles on the road graph, each on the
road ``(e, s, v)`` or off it ``(x, y, vx, vy)``, with normalised weights
(:class:`gcs.core.roads.particles.RoadParticles`; the motion of
:class:`gcs.core.roads.particle.RoadParticleFilter`, after Arulampalam, Gordon,
Orton and Ristic 2002). :class:`TrackClouds` keeps every track's particles in one
flat cloud of ``T P`` particles, row ``t`` holding particles ``t P .. t P + P - 1``,
so that one call moves, weighs or summarises every track.

* **Start** (:func:`start_clouds`): a new track's Gaussian ``[x, y, vx, vy]`` (an
  inverted detection, the velocity unknown) is sampled, each draw put on the
  nearest road in the direction of its velocity
  (:func:`gcs.core.roads.particles.aligned`), a share ``initial_off_road`` left off it.
* **Summary** (:meth:`TrackClouds.summary`): the moment-matched ``cv2d`` mean and
  covariance of each track, ``x = sum_i w_i x_i``, ``P = sum_i w_i (x_i - x)(x_i - x)^T``
  (:func:`gcs.core.roads.outputs.moment_match`), what gating, initiation and the
  lifecycle see of a road track, and what is reported.
* **Resampling** (:func:`resample_degenerate`): systematic resampling (Kitagawa
  1996) of every track whose effective sample size ``1 / sum_i w_i^2`` is under
  ``threshold P``, each row with its own uniform offset, then the road particles
  moved by ``N(0, spread_m^2)`` along their edge and the off-road ones in the plane
  (regularisation, Musso, Oudjane and Le Gland 2001), as the single-target filter does.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gcs.core.roads.graph import RoadGraph
from gcs.core.roads.model import RoadMotion
from gcs.core.roads.outputs import moment_match
from gcs.core.roads.particle import RoadParticleFilter
from gcs.core.roads.particles import RoadParticles, aligned

__all__ = ["TrackClouds", "start_clouds", "drive", "resample_degenerate", "systematic_rows"]

_FIELDS = ("edge", "s", "speed", "on_road", "xy", "vxy", "log_weight")


@dataclass(frozen=True, eq=False)
class TrackClouds:
    """The road tracks' state besides their :class:`~gcs.core.multitarget.tracks.TrackSet` rows (module docstring).

    Per particle (``per_track`` a track, row-major): ``cloud`` (a flat :class:`RoadParticles`) and ``lateral``,
    the offset from the centre line (m, left of the edge's direction; unused off the road). Per track:
    ``existence``, the probability that the track is a target's
    (:mod:`~gcs.core.multitarget.road_existence`), and ``unresolved``, the consecutive scans it has
    been unresolved from an older track (:mod:`~gcs.core.multitarget.road_merging`).
    """

    cloud: RoadParticles
    lateral: NDArray[np.float64]
    existence: NDArray[np.float64]
    unresolved: NDArray[np.int64]
    per_track: int

    @classmethod
    def empty(cls, per_track: int) -> TrackClouds:
        """No tracks."""
        cloud = RoadParticles(np.zeros(0, dtype=np.intp), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool),
                              np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
        return cls(cloud, np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64), per_track)

    @property
    def tracks(self) -> int:
        """Number of tracks T."""
        return len(self.existence)

    def rows(self, name: str) -> NDArray[Any]:
        """A per-particle field (of the cloud, or ``lateral``) shaped per track: (T, P) or (T, P, 2)."""
        value = self.lateral if name == "lateral" else getattr(self.cloud, name)
        return value.reshape((self.tracks, self.per_track) + value.shape[1:])

    @property
    def log_weights(self) -> NDArray[np.float64]:
        """(T, P), each row normalised."""
        return self.rows("log_weight")

    def positions(self, graph: RoadGraph) -> NDArray[np.float64]:
        """Every particle's ENU position (T P, 2): on the road ``p(e, s) + l n_e`` (``n_e`` the edge's left normal)."""
        cloud = self.cloud
        direction = graph.direction[cloud.edge]
        offset = np.where(cloud.on_road, self.lateral, 0.0)[:, None]
        positions: NDArray[np.float64] = cloud.xy + offset * np.stack([-direction[:, 1], direction[:, 0]], axis=1)
        return positions

    def select(self, rows: NDArray[np.bool_] | NDArray[np.intp]) -> TrackClouds:
        """The tracks ``rows`` (a mask or indices), in that order."""
        picked = {name: self.rows(name)[rows] for name in _FIELDS + ("lateral",)}
        flat = {n: v.reshape((-1,) + v.shape[2:]) for n, v in picked.items()}
        lateral = flat.pop("lateral")
        return TrackClouds(RoadParticles(**flat), lateral, self.existence[rows], self.unresolved[rows],
                           self.per_track)

    def concat(self, other: TrackClouds) -> TrackClouds:
        """These tracks followed by ``other``'s."""
        cloud = RoadParticles(**{n: np.concatenate([getattr(self.cloud, n), getattr(other.cloud, n)])
                                 for n in _FIELDS})
        return TrackClouds(cloud, np.concatenate([self.lateral, other.lateral]),
                           np.concatenate([self.existence, other.existence]),
                           np.concatenate([self.unresolved, other.unresolved]), self.per_track)

    def with_log_weights(self, log_weights: NDArray[np.float64]) -> TrackClouds:
        """The same particles with new log-weights (T, P)."""
        return replace(self, cloud=replace(self.cloud, log_weight=np.asarray(log_weights, dtype=np.float64).ravel()))

    def summary(self, graph: RoadGraph) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Moment-matched ``[x, y, vx, vy]`` means (T, 4) and covariances (T, 4, 4) (module docstring)."""
        shape = (self.tracks, self.per_track, 2)
        states = np.concatenate([self.positions(graph).reshape(shape), self.rows("vxy")], axis=2)
        return moment_match(np.exp(self.log_weights), states)


def start_clouds(motion: RoadMotion, mean: NDArray[np.float64], cov: NDArray[np.float64], per_track: int,
                 lane_std_m: float, existence: float, rng: np.random.Generator) -> TrackClouds:
    """Clouds of new tracks from Gaussians ``[x, y, vx, vy]``: means (k, 4), covariances (k, 4, 4) (module docstring).

    A draw farther than ``rejoin_m`` from every road stays off the road (a detection in
    a car park, or clutter outside the city, is no car on a street)."""
    k = len(mean)
    if k == 0:
        return TrackClouds.empty(per_track)
    graph = motion.graph
    factor = np.linalg.cholesky(cov + 1e-9 * np.eye(4))
    draws = (mean[:, None, :] + rng.standard_normal((k, per_track, 4)) @ factor.swapaxes(-1, -2)).reshape(-1, 4)
    edge, s, gap = graph.snap(draws[:, :2], within_m=motion.rejoin_m)
    near = gap <= motion.rejoin_m
    edge, s, speed = aligned(graph, np.where(near, edge, 0), np.where(near, s, 0.0), draws[:, 2:])
    on_road = near & (rng.random(len(draws)) >= motion.initial_off_road)
    lateral = lane_std_m * rng.standard_normal(len(draws))
    cloud = RoadParticles.build(graph, edge, s, np.minimum(speed, motion.max_speed_mps), on_road, draws[:, :2],
                                draws[:, 2:], np.full(len(draws), -np.log(per_track)))
    return TrackClouds(cloud, lateral, np.full(k, existence), np.zeros(k, dtype=np.int64), per_track)


def drive(motion: RoadParticleFilter, clouds: TrackClouds, dt_s: float, lateral_psd_m2_s: float, lateral_limit_m: float,
          rng: np.random.Generator) -> TrackClouds:
    """Every particle moved on ``dt_s`` seconds (:meth:`RoadParticleFilter.move`), its lateral offset a random walk
    of density ``lateral_psd_m2_s`` kept within ``lateral_limit_m`` of the centre line."""
    cloud = motion.move(clouds.cloud, dt_s, rng)
    lateral = clouds.lateral + np.sqrt(lateral_psd_m2_s * dt_s) * rng.standard_normal(len(clouds.lateral))
    return replace(clouds, cloud=cloud, lateral=np.clip(lateral, -lateral_limit_m, lateral_limit_m))


def systematic_rows(weights: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.intp]:
    """Systematic resampling of every row of ``weights`` (R, P) at once: the picked column per row and draw (R, P)."""
    rows, p = weights.shape
    cumulative = np.cumsum(weights, axis=1)
    cumulative /= cumulative[:, -1:]
    offsets = np.arange(rows)[:, None]
    positions = (rng.random((rows, 1)) + np.arange(p)) / p
    picked = np.searchsorted((cumulative + offsets).ravel(), (positions + offsets).ravel()).reshape(rows, p)
    columns: NDArray[np.intp] = np.clip(picked - offsets * p, 0, p - 1)
    return columns


def resample_degenerate(motion: RoadMotion, clouds: TrackClouds, threshold: float,
                        rng: np.random.Generator) -> TrackClouds:
    """Resample the tracks whose effective sample size is under ``threshold P``, then regularise them (module
    docstring); the other tracks are left as they are."""
    if clouds.tracks == 0:
        return clouds
    weights = np.exp(clouds.log_weights)
    p = clouds.per_track
    low = np.flatnonzero(1.0 / np.sum(weights * weights, axis=1) < threshold * p)
    if low.size == 0:
        return clouds
    picked = (systematic_rows(weights[low], rng) + (low * p)[:, None]).ravel()
    targets = (low[:, None] * p + np.arange(p)).ravel()
    old = clouds.cloud
    fields = {n: getattr(old, n).copy() for n in _FIELDS}
    for name in _FIELDS:
        fields[name][targets] = getattr(old, name)[picked]
    lateral = clouds.lateral.copy()
    lateral[targets] = clouds.lateral[picked]
    graph, n = motion.graph, len(targets)
    on_road, edge = fields["on_road"][targets], fields["edge"][targets]
    jitter = motion.spread_m * rng.standard_normal(n)
    fields["s"][targets] = np.clip(fields["s"][targets] + np.where(on_road, jitter, 0.0), 0.0, graph.length[edge])
    fields["xy"][targets] += np.where(on_road, 0.0, motion.spread_m)[:, None] * rng.standard_normal((n, 2))
    fields["log_weight"][targets] = -np.log(p)
    cloud = RoadParticles.build(graph, fields["edge"], fields["s"], fields["speed"], fields["on_road"], fields["xy"],
                                fields["vxy"], fields["log_weight"])
    return replace(clouds, cloud=cloud, lateral=lateral)
