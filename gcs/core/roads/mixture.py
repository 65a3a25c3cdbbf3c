"""A Gaussian mixture on road coordinates with an off-road mode (Ulmke and Koch 2006).

**State.** Road component ``c`` lives on directed edge ``e_c`` with
``(s, v) ~ N(m_c, P_c)``: arc length and speed along the edge; its target is at
``p = n_{tail} + s d_e``. The off-road mode is one ``[x, y, vx, vy]`` Gaussian.
Weights ``w_c`` and ``w_off`` sum to 1.

**Prediction over dt.** Along the road the speed is a white-noise acceleration
(``q_s``): ``F = [[1, dt], [0, 1]]``, ``Q = q_s [[dt^3/3, dt^2/2], [dt^2/2, dt]]``.
Then **branching** (as Ulmke and Koch 2006 split at junctions): the probability mass of a
component beyond the end of its edge, ``alpha = P(s > l_e) = Phi((m_s - l_e) / sigma_s)``,
is cut off (the truncated normal's moments, :mod:`gcs.core.roads.mixture_parts`)
and continues on every successor ``e'`` with weight ``w alpha T[e, e']`` at
``s - l_e``; the mass before the node stays, weight ``w (1 - alpha)``. Parts
below ``SPLIT_MIN`` of a component's mass are not split off.
Mode switches: ``1 - exp(-lambda_off dt)`` of the road mass leaves the road (the
off-road Gaussian becomes the moment-matched merge of itself and the road
mixture's summary), and ``1 - exp(-lambda_on dt)`` of the off-road mass joins the
nearest road edge within ``rejoin_m`` (a new component, its state the off-road
Gaussian projected on the edge). Off the road: wang2012 eq. (2)'s constant
velocity (``q_off``).

**Update.** Every component by the iterated EKF on the step's stacked
detections (:func:`gcs.core.roads.gaussian_update.update_components`), its
weight multiplied by the marginal likelihood of the detections and by the
looks' factors averaged over three points along the edge, ``s = m_s + sigma_s a``
with ``a`` in ``{-sqrt(3/2), 0, sqrt(3/2)}`` (the three-point Gauss-Hermite rule,
:data:`QUADRATURE`): a branch a UAV had in sight and found empty loses weight
(Koch 2007). Along the edge a component is kept to ``v >= 0`` and ``s >= 0``
(:func:`~gcs.core.roads.mixture_parts.forward_only`): a car turning round is a
component on the reverse edge.

**Merge and prune.** Components on the same edge closer than ``MERGE_D2``
(Mahalanobis, the lighter against the heavier) are moment-matched into one;
those lighter than ``prune_weight`` are dropped and at most ``max_components``
kept (mixture reduction by joining, Salmond 1990).

**Recovery.** As the particle filter: detections that no component explains
restart the mixture about them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from gcs.core.filters.estimate import NS_PER_S, GaussianEstimate
from gcs.core.models.motion import constant_velocity
from gcs.core.roads.model import RoadMotion
from gcs.core.roads.gaussian_update import update_components
from gcs.core.roads.mixture_parts import (RoadComponents, branch, forward_only, merge_and_prune, road_summary,
                                          start_components)
from gcs.core.roads.outputs import RoadHorizon, forward_stamp, moment_match, normalise_log_weights
from gcs.core.roads.particles import aligned, invert_detections
from gcs.core.roads.sensing import DetectionGroup, Looks, looks_log_likelihood

__all__ = ["RoadMixtureFilter", "RoadMixtureEstimate"]

RECOVERY_PROBABILITY = 1e-6
QUADRATURE = np.array([-1.2247448713915890, 0.0, 1.2247448713915890])
"""Three-point Gauss-Hermite abscissae (in standard deviations), equal weights 1/3 (variance kept exactly)."""


@dataclass(frozen=True)
class RoadMixtureEstimate(GaussianEstimate):
    """The moment-matched ``cv2d`` summary (``mean`` (4,), ``cov`` (4, 4), ``stamp_ns``) and the components."""

    components: RoadComponents = field(kw_only=True)

    @property
    def off_road_probability(self) -> float:
        """Weight of the off-road mode."""
        return float(np.exp(self.components.off_log_weight))

    def branch_weights(self) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """The edges holding road components and the weight on each, heaviest first (the most likely branch first)."""
        comp = self.components
        edges, inverse = np.unique(comp.edge, return_inverse=True)
        mass = np.bincount(inverse, weights=np.exp(comp.log_weight), minlength=len(edges)).astype(np.float64)
        order = np.argsort(-mass)
        return edges[order], mass[order]


@dataclass(frozen=True)
class RoadMixtureFilter(RoadMotion):
    """Parameters of the road Gaussian mixture (module docstring; :class:`RoadMotion`); holds no estimate."""

    max_components: int = 24
    prune_weight: float = 1e-3

    def start(self, initial: GaussianEstimate, rng: np.random.Generator) -> RoadMixtureEstimate:
        """Components on the edges near a Gaussian ``[x, y, vx, vy]``, both ways, and the off-road mode."""
        components = start_components(self.graph, initial, self.initial_off_road, self.spread_m, rng)
        return self._estimate(components, initial.stamp_ns)

    def predict(self, estimate: RoadMixtureEstimate, stamp_ns: int, rng: np.random.Generator | None = None
                ) -> RoadMixtureEstimate:
        """Predict to ``stamp_ns`` (module docstring); deterministic (``rng`` is not used)."""
        stamp_ns = forward_stamp(estimate, stamp_ns)
        if stamp_ns == estimate.stamp_ns:
            return estimate
        return self._estimate(self._move(estimate.components, (stamp_ns - estimate.stamp_ns) / NS_PER_S), stamp_ns)

    def _move(self, comp: RoadComponents, dt: float) -> RoadComponents:
        graph = self.graph
        f = np.array([[1.0, dt], [0.0, 1.0]])
        q = self.speed_psd_m2_s3 * np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
        mean, cov = forward_only(comp.mean @ f.T, f @ comp.cov @ f.T + q)
        edge, mean, cov, log_w = branch(graph, self.table, comp.edge, mean, cov, comp.log_weight)
        f4, q4 = constant_velocity(self.off_road_psd_m2_s3).matrices(dt)
        off_mean, off_cov = f4 @ comp.off_mean, f4 @ comp.off_cov @ f4.T + q4
        leave, rejoin = -np.expm1(-self.leave_rate_per_s * dt), -np.expm1(-self.rejoin_rate_per_s * dt)
        road_w = np.exp(log_w)
        off_w = float(np.exp(comp.off_log_weight))
        if len(edge):  # road -> off road: the road mixture's summary joins the off-road Gaussian
            summary_mean, summary_cov = road_summary(graph, edge, mean, cov, road_w, self.spread_m)
            stay = off_w * (1.0 - rejoin)
            arrive = leave * road_w.sum()
            w = np.array([stay, arrive]) / max(stay + arrive, 1e-300)
            off_mean, off_cov = moment_match(w, np.stack([off_mean, summary_mean]), np.stack([off_cov, summary_cov]))
            road_w = road_w * (1.0 - leave)
            off_w = stay + arrive
        e_new, s_new, gap = graph.snap(off_mean[:2])
        if gap <= self.rejoin_m:  # off road -> road: the off-road Gaussian projected on the nearest edge
            e_join, s_join, speed = aligned(graph, np.array([e_new]), np.array([s_new]), off_mean[None, 2:4])
            d = graph.direction[e_join[0]]
            basis = np.zeros((2, 4))
            basis[0, :2], basis[1, 2:] = d, d
            edge = np.append(edge, e_join)
            mean = np.concatenate([mean, [[s_join[0], speed[0]]]])
            cov = np.concatenate([cov, (basis @ off_cov @ basis.T)[None]])
            road_w = np.append(road_w, off_w * rejoin)
            off_w *= 1.0 - rejoin
        with np.errstate(divide="ignore"):
            return merge_and_prune(RoadComponents(edge, mean, cov, np.log(road_w), off_mean, off_cov, np.log(off_w)),
                                   self.max_components, self.prune_weight)

    def update(self, prior: RoadMixtureEstimate, groups: Sequence[DetectionGroup], looks: Looks | None,
               rng: np.random.Generator) -> RoadMixtureEstimate:
        """Update every component and reweigh the mixture (module docstring); ``rng`` draws the restart's components
        when the detections fit no component."""
        comp = prior.components
        if not groups and looks is None:
            return prior
        graph, spread2 = self.graph, self.spread_m**2
        mean, cov, log_w = comp.mean, comp.cov, comp.log_weight
        off_mean, off_cov, off_log_w = comp.off_mean, comp.off_cov, comp.off_log_weight
        if groups:
            d = graph.direction[comp.edge]
            basis = np.zeros((len(comp.edge), 2, 2))
            basis[:, :, 0] = d
            mean, cov, road_lik, road_d2 = update_components(comp.mean, comp.cov, graph.nodes[graph.tail[comp.edge]],
                                                             basis, groups, spread2)
            off_basis = np.eye(2, 4)[None]
            o_mean, o_cov, off_lik, off_d2 = update_components(comp.off_mean[None], comp.off_cov[None],
                                                               np.zeros((1, 2)), off_basis, groups, spread2)
            dof = sum(np.size(z) for _, z, _, _ in groups)
            best = min(road_d2.min(initial=np.inf), off_d2[0])
            if best > chi2.isf(RECOVERY_PROBABILITY, dof):
                fix = invert_detections(groups)
                if fix is not None:
                    cov0 = np.diag([0.0, 0.0, 100.0, 100.0])
                    cov0[:2, :2] = fix[1]
                    restart = self.start(GaussianEstimate(np.append(fix[0], [0.0, 0.0]), cov0, prior.stamp_ns), rng)
                    return self.update(restart, groups, looks, rng)
            log_w = log_w + road_lik
            off_mean, off_cov, off_log_w = o_mean[0], o_cov[0], off_log_w + off_lik[0]
        if looks is not None and len(comp.edge):
            s = comp.mean[:, 0:1] + np.sqrt(comp.cov[:, 0, 0])[:, None] * QUADRATURE
            points = graph.position(np.repeat(comp.edge[:, None], 3, axis=1), s).reshape(-1, 2)
            factor = np.exp(looks_log_likelihood(np.concatenate([points, comp.off_mean[None, :2]]), looks))
            log_w = log_w + np.log(factor[:-1].reshape(-1, 3).mean(axis=1))
            off_log_w = off_log_w + np.log(factor[-1])
        all_w, _ = normalise_log_weights(np.append(log_w, off_log_w))
        updated = RoadComponents(comp.edge, mean, cov, all_w[:-1], off_mean, off_cov, float(all_w[-1]))
        return self._estimate(merge_and_prune(updated, self.max_components, self.prune_weight), prior.stamp_ns)

    def step(self, estimate: RoadMixtureEstimate, stamp_ns: int, groups: Sequence[DetectionGroup],
             looks: Looks | None, rng: np.random.Generator) -> RoadMixtureEstimate:
        """:meth:`predict` then :meth:`update`."""
        return self.update(self.predict(estimate, stamp_ns), groups, looks, rng)

    def _estimate(self, comp: RoadComponents, stamp_ns: int) -> RoadMixtureEstimate:
        states, covs, weights = comp.enu(self.graph, self.spread_m)
        mean, cov = moment_match(weights, states, covs)
        return RoadMixtureEstimate(mean, cov, stamp_ns, components=comp)

    def horizon(self, estimate: RoadMixtureEstimate, step_s: float, steps: int,
                rng: np.random.Generator | None = None, samples: int = 64) -> RoadHorizon:
        """k+1..k+n: the mixture predicted on (branching), each road component as three weighted points along its
        edge (:data:`QUADRATURE`), the off-road mode as its mean; padded with zero weights to ``samples``."""
        if steps < 1:
            raise ValueError(f"steps must be >= 1, got {steps}")
        step_ns = int(round(step_s * NS_PER_S))
        comp = estimate.components
        states = np.zeros((steps, samples, 4))
        weights = np.zeros((steps, samples))
        off_road = np.zeros(steps)
        for j in range(steps):
            comp = self._move(comp, step_ns / NS_PER_S)
            points, point_w = comp.points(self.graph, QUADRATURE)
            keep = np.argsort(-point_w)[:samples]
            states[j, :len(keep)], weights[j, :len(keep)] = points[keep], point_w[keep]
            weights[j] /= weights[j].sum()
            off_road[j] = np.exp(comp.off_log_weight)
        stamps = tuple(estimate.stamp_ns + j * step_ns for j in range(1, steps + 1))
        return RoadHorizon.from_samples(stamps, states, weights, off_road)

    def log_likelihood(self, estimate: RoadMixtureEstimate, group: DetectionGroup) -> NDArray[np.float64]:
        """``ln p(z_j | track) = ln sum_c w_c N(z_j; h(p_c), S_c)`` of each detection of a group (k,)."""
        sensor, z, xyz, covs = group
        comp, graph = estimate.components, self.graph
        d = graph.direction[comp.edge]
        basis = np.zeros((len(comp.edge), 2, 2))
        basis[:, :, 0] = d
        out = []
        for j in range(len(z)):
            one = [(sensor, z[j:j + 1], xyz[j:j + 1], None if covs is None else covs[j:j + 1])]
            _, _, road, _ = update_components(comp.mean, comp.cov, graph.nodes[graph.tail[comp.edge]], basis, one,
                                              self.spread_m**2)
            _, _, off, _ = update_components(comp.off_mean[None], comp.off_cov[None], np.zeros((1, 2)),
                                             np.eye(2, 4)[None], one, self.spread_m**2)
            joint = np.append(road + comp.log_weight, off[0] + comp.off_log_weight)
            top = joint.max()
            out.append(top + np.log(np.exp(joint - top).sum()))
        return np.array(out)
