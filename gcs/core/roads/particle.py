"""A particle filter on the road graph with an off-road mode (Arulampalam et al. 2002; Ristic et al. 2004).

**State.** Particle ``i`` is either *on the road*: ``(e_i, s_i, v_i)``, the
directed edge, the arc length along it and the speed along it (m/s, >= 0); or
*off the road*: ``(x_i, y_i, vx_i, vy_i)`` on the plane. Its ENU position is
``p(e_i, s_i)`` (:class:`~gcs.core.roads.graph.RoadGraph`) or ``(x_i, y_i)``.

**Motion over dt** (the variable-structure multiple-model particle filter of
Arulampalam, Gordon, Orton and Ristic 2002, with the road as the structure):

1. mode switch: a road particle leaves the road with probability
   ``1 - exp(-lambda_off dt)`` (keeping its position and velocity ``v d_e``); an
   off-road particle within ``rejoin_m`` of a road rejoins it with probability
   ``1 - exp(-lambda_on dt)``, on the nearest edge, in the direction of its
   velocity, at speed ``|v . d_e|``;
2. on the road: the speed is a random walk, ``v' = clip(v + sqrt(q_s dt) w, 0,
   v_max)``, and the particle drives ``(v + v') dt / 2`` through the graph
   (:func:`~gcs.core.roads.walk.walk`), drawing a successor at each node crossed
   with the branch probabilities ``T[e, k]`` (straight on ``1 - p_turn``, the turns
   sharing ``p_turn``): the hypotheses **branch** at junctions;
3. off the road: the white-noise-acceleration model of wang2012 eq. (2), sampled
   exactly (``q_off``).

**Update.** Weights are multiplied by ``p(Z | x_i)`` of the step's detections
(every vehicle's, fused as the DUIF fuses them, :mod:`gcs.core.roads.sensing`)
and by the looks' factors (negative information, Koch 2007): a branch a UAV
had in sight and found empty loses weight, one it detected gains. Branches
**merge** again on a detection: the particles far from it lose their weight
and resampling (systematic, when the effective sample size ``1 / sum w^2`` falls
below ``resample_threshold P``) drops them. After resampling every particle is
moved by ``N(0, spread_m^2)`` along its edge (regularisation, Musso et al. 2001),
the same spread the likelihood allows for (a point stands for a few metres of road).

**Recovery.** When no particle explains a step's range detections (the best
particle's normalised squared residual exceeds the chi-square quantile
``1 - 1e-6``), the cloud is drawn again about the detections (:meth:`RoadParticleFilter.start`).

Conventions: the filter holds parameters only; ``predict``/``update`` take an
estimate and return a new one; time is integer nanoseconds and randomness a
``numpy.random.Generator`` argument.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from gcs.core.filters.estimate import NS_PER_S, GaussianEstimate
from gcs.core.roads.model import RoadMotion
from gcs.core.roads.outputs import RoadHorizon, forward_stamp, moment_match, normalise_log_weights
from gcs.core.roads.particles import RoadParticles, aligned, invert_detections, systematic
from gcs.core.roads.sensing import (DetectionGroup, Looks, detection_log_likelihoods, detections_log_likelihood,
                                    looks_log_likelihood)
from gcs.core.roads.walk import walk

__all__ = ["RoadParticleFilter", "RoadParticleEstimate"]

RECOVERY_PROBABILITY = 1e-6
"""Tail probability of the chi-square test that says no particle explains the detections."""


@dataclass(frozen=True)
class RoadParticleEstimate(GaussianEstimate):
    """The moment-matched ``cv2d`` summary (``mean`` (4,), ``cov`` (4, 4), ``stamp_ns``) and the particles."""

    particles: RoadParticles = field(kw_only=True)

    @property
    def off_road_probability(self) -> float:
        """Weight of the off-road mode."""
        return float(self.particles.weights[~self.particles.on_road].sum())

    def branch_weights(self) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """The edges holding road hypotheses and the weight on each, heaviest first (the most likely branch first)."""
        return self.particles.branch_weights()


@dataclass(frozen=True)
class RoadParticleFilter(RoadMotion):
    """Parameters of the road particle filter (module docstring; :class:`RoadMotion`); holds no estimate."""

    particles: int = 400
    resample_threshold: float = 0.5

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.particles < 2:
            raise ValueError(f"particles must be >= 2, got {self.particles}")

    def start(self, initial: GaussianEstimate, rng: np.random.Generator) -> RoadParticleEstimate:
        """Particles drawn from a Gaussian ``[x, y, vx, vy]`` (a detection inverted, an ML fix), then put on the
        nearest road in the direction of their velocity, ``initial_off_road`` of them left off it."""
        n = self.particles
        draws = rng.multivariate_normal(initial.mean[:4], initial.cov[:4, :4], size=n)
        edge, s, _ = self.graph.snap(draws[:, :2])
        edge, s, speed = aligned(self.graph, edge, s, draws[:, 2:4])
        on_road = rng.random(n) >= self.initial_off_road
        cloud = RoadParticles.build(self.graph, edge, s, np.minimum(speed, self.max_speed_mps), on_road,
                                    draws[:, :2], draws[:, 2:4], np.full(n, -np.log(n)))
        return self._estimate(cloud, initial.stamp_ns)

    def predict(self, estimate: RoadParticleEstimate, stamp_ns: int, rng: np.random.Generator) -> RoadParticleEstimate:
        """Move every particle to ``stamp_ns`` (module docstring, motion steps 1-3)."""
        stamp_ns = forward_stamp(estimate, stamp_ns)
        if stamp_ns == estimate.stamp_ns:
            return estimate
        cloud = self.move(estimate.particles, (stamp_ns - estimate.stamp_ns) / NS_PER_S, rng)
        return self._estimate(cloud, stamp_ns)

    def move(self, cloud: RoadParticles, dt: float, rng: np.random.Generator) -> RoadParticles:
        """Every particle of ``cloud`` moved on by ``dt`` seconds (module docstring, motion steps 1-3); weights kept."""
        graph, n = self.graph, len(cloud.s)
        on_road = cloud.on_road.copy()
        edge, s, speed = cloud.edge.copy(), cloud.s.copy(), cloud.speed.copy()
        xy, vxy = cloud.xy.copy(), cloud.vxy.copy()
        u = rng.random(n)
        leaving = on_road & (u < -np.expm1(-self.leave_rate_per_s * dt))
        vxy[leaving] = speed[leaving, None] * graph.direction[edge[leaving]]
        candidates = np.flatnonzero(~on_road & (u < -np.expm1(-self.rejoin_rate_per_s * dt)))
        if candidates.size:
            e_new, s_new, gap = graph.snap(xy[candidates], within_m=self.rejoin_m)
            near = candidates[gap <= self.rejoin_m]
            e_near, s_near = e_new[gap <= self.rejoin_m], s_new[gap <= self.rejoin_m]
            edge[near], s[near], speed[near] = aligned(graph, e_near, s_near, vxy[near])
            on_road[near] = True
        on_road[leaving] = False
        road = np.flatnonzero(on_road)
        new_speed = np.clip(speed[road] + np.sqrt(self.speed_psd_m2_s3 * dt) * rng.standard_normal(road.size),
                            0.0, self.max_speed_mps)
        edge[road], s[road] = walk(graph, self.table, edge[road], s[road], 0.5 * (speed[road] + new_speed) * dt, rng)
        speed[road] = new_speed
        off = np.flatnonzero(~on_road)
        if off.size:  # exact sample of the white-noise acceleration over dt, per axis (wang2012 eq. 2)
            q = self.off_road_psd_m2_s3  # Cholesky factor of q [[dt^3/3, dt^2/2], [dt^2/2, dt]]: [[a, 0], [b, c]]
            a = np.sqrt(q * dt**3 / 3.0)
            b = 0.5 * np.sqrt(3.0 * q * dt)
            factor = np.array([[a, 0.0], [b, np.sqrt(max(q * dt - b * b, 0.0))]])
            noise = rng.standard_normal((off.size, 2, 2)) @ factor.T  # (n, axis, [pos, vel])
            xy[off] += vxy[off] * dt + noise[:, :, 0]
            vxy[off] += noise[:, :, 1]
        return RoadParticles.build(graph, edge, s, speed, on_road, xy, vxy, cloud.log_weight)

    def update(self, prior: RoadParticleEstimate, groups: Sequence[DetectionGroup], looks: Looks | None,
               rng: np.random.Generator) -> RoadParticleEstimate:
        """Weigh the particles by the detections and the looks, resample when degenerate (module docstring)."""
        cloud = prior.particles
        if not groups and looks is None:
            return prior
        spread2 = self.spread_m**2
        log_lik, d2 = detections_log_likelihood(cloud.xy, groups, spread2)
        components = sum(np.size(z) for _, z, _, _ in groups)
        if components and d2.min() > chi2.isf(RECOVERY_PROBABILITY, components):
            fix = invert_detections(groups)
            if fix is not None:
                restart = GaussianEstimate(np.append(fix[0], [0.0, 0.0]), _fix_cov(fix[1]), prior.stamp_ns)
                start = self.start(restart, rng)
                return self.update(start, groups, looks, rng)
        log_w, _ = normalise_log_weights(cloud.log_weight + log_lik + looks_log_likelihood(cloud.xy, looks))
        cloud = replace(cloud, log_weight=log_w)
        weights = np.exp(log_w)
        if 1.0 / np.sum(weights * weights) < self.resample_threshold * len(weights):
            cloud = self._resample(cloud, rng)
        return self._estimate(cloud, prior.stamp_ns)

    def step(self, estimate: RoadParticleEstimate, stamp_ns: int, groups: Sequence[DetectionGroup],
             looks: Looks | None, rng: np.random.Generator) -> RoadParticleEstimate:
        """:meth:`predict` then :meth:`update`."""
        return self.update(self.predict(estimate, stamp_ns, rng), groups, looks, rng)

    def _resample(self, cloud: RoadParticles, rng: np.random.Generator) -> RoadParticles:
        pick = systematic(np.exp(cloud.log_weight), rng)
        n = len(pick)
        jitter = self.spread_m * rng.standard_normal(n)
        edge, on_road = cloud.edge[pick], cloud.on_road[pick]
        s = np.clip(cloud.s[pick] + np.where(on_road, jitter, 0.0), 0.0, self.graph.length[edge])
        xy = cloud.xy[pick] + np.where(on_road, 0.0, self.spread_m)[:, None] * rng.standard_normal((n, 2))
        return RoadParticles.build(self.graph, edge, s, cloud.speed[pick], on_road, xy, cloud.vxy[pick],
                                   np.full(n, -np.log(n)))

    def _estimate(self, cloud: RoadParticles, stamp_ns: int) -> RoadParticleEstimate:
        mean, cov = moment_match(np.exp(cloud.log_weight), cloud.states)
        return RoadParticleEstimate(mean, cov, stamp_ns, particles=cloud)

    def horizon(self, estimate: RoadParticleEstimate, step_s: float, steps: int, rng: np.random.Generator,
                samples: int = 64) -> RoadHorizon:
        """k+1..k+n: ``samples`` particles drawn by weight, each driven on through the graph (branching). Each
        step's samples come grouped by branch: by edge, then arc length along it, the off-road ones last."""
        if steps < 1:
            raise ValueError(f"steps must be >= 1, got {steps}")
        cloud = estimate.particles.subset(systematic(estimate.particles.weights, rng, samples))
        step_ns = int(round(step_s * NS_PER_S))
        states, off_road = [], []
        for _ in range(steps):
            cloud = self.move(cloud, step_ns / NS_PER_S, rng)
            by_branch = np.lexsort((cloud.xy[:, 1], cloud.xy[:, 0], cloud.s, np.where(cloud.on_road, cloud.edge, -1),
                                    ~cloud.on_road))
            states.append(cloud.states[by_branch])
            off_road.append(1.0 - cloud.on_road.mean())
        stamps = tuple(estimate.stamp_ns + j * step_ns for j in range(1, steps + 1))
        return RoadHorizon.from_samples(stamps, np.stack(states), np.full((steps, samples), 1.0 / samples),
                                        np.array(off_road))

    def log_likelihood(self, estimate: RoadParticleEstimate, group: DetectionGroup) -> NDArray[np.float64]:
        """``ln p(z_j | track) = ln sum_i w_i N(z_j; h(x_i), R)`` of each detection of a group (k,): the
        many-target tracker's association score."""
        log_lik, _ = detection_log_likelihoods(estimate.particles.xy, group, self.spread_m**2)
        joint = log_lik + estimate.particles.log_weight[:, None]
        top = joint.max(axis=0)
        log_sum: NDArray[np.float64] = top + np.log(np.exp(joint - top).sum(axis=0))
        return log_sum


def _fix_cov(position_cov: NDArray[np.float64]) -> NDArray[np.float64]:
    cov = np.diag([0.0, 0.0, 100.0, 100.0])
    cov[:2, :2] = position_cov
    return cov
