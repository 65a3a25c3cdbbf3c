"""The components of :mod:`gcs.core.roads.mixture` and the operations on them: branching at nodes (truncated
Gaussians), merging and pruning, the ENU view, and the first components of a track.

**Truncation.** For ``s ~ N(mu, sigma^2)`` and the node at ``l`` (``a = (l - mu) / sigma``),
the part beyond the node has mass ``1 - Phi(a)``, mean ``mu + sigma lambda`` and
variance ``sigma^2 (1 + a lambda - lambda^2)`` with ``lambda = phi(a) / (1 - Phi(a))``;
the part before it mass ``Phi(a)``, mean ``mu - sigma lambda'`` and variance
``sigma^2 (1 - a lambda' - lambda'^2)`` with ``lambda' = phi(a) / Phi(a)``
(Johnson, Kotz and Balakrishnan 1994, ch. 13). The speed follows by its
regression on ``s``: with ``beta = P_sv / P_ss``, ``E v = m_v + beta (E s - m_s)``,
``Var v = P_vv - beta P_sv + beta^2 Var s``, ``Cov(s, v) = beta Var s``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from gcs.core.filters.estimate import GaussianEstimate
from gcs.core.roads.graph import RoadGraph
from gcs.core.roads.outputs import moment_match

__all__ = ["RoadComponents", "branch", "forward_only", "merge_and_prune", "road_summary", "start_components",
           "SPLIT_MIN", "MERGE_D2"]

SPLIT_MIN = 0.01
"""Mass beyond (or before) a node below which a component is not split there."""
MERGE_D2 = 1.0
"""Squared Mahalanobis distance (in the heavier component's metric) below which two components of an edge merge."""
MAX_PASSES = 8
"""Nodes one component may cross in one prediction."""
START_SAMPLES = 64
"""Draws of the initial Gaussian snapped to the roads to find a new track's edges."""
_INV_SQRT_2PI = 1.0 / np.sqrt(2.0 * np.pi)


@dataclass(frozen=True, eq=False)
class RoadComponents:
    """C road components: ``edge`` (C,), ``mean`` (C, 2) = (s, v), ``cov`` (C, 2, 2), ``log_weight`` (C,); and
    the off-road Gaussian ``off_mean`` (4,), ``off_cov`` (4, 4), ``off_log_weight``. Weights sum to 1."""

    edge: NDArray[np.intp]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    log_weight: NDArray[np.float64]
    off_mean: NDArray[np.float64]
    off_cov: NDArray[np.float64]
    off_log_weight: float

    def enu(self, graph: RoadGraph, spread_m: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Every component as ``[x, y, vx, vy]``: states (C + 1, 4), covariances (C + 1, 4, 4), weights (C + 1,);
        a road component's position has the lateral variance ``spread_m^2`` across its edge; the off-road mode last."""
        d = graph.direction[self.edge]
        basis = np.zeros((len(self.edge), 4, 2))
        basis[:, :2, 0], basis[:, 2:, 1] = d, d
        states = np.einsum("cij,cj->ci", basis, self.mean)
        states[:, :2] += graph.nodes[graph.tail[self.edge]]
        covs = basis @ self.cov @ basis.swapaxes(-1, -2)
        normal = np.stack([-d[:, 1], d[:, 0]], axis=1)
        covs[:, :2, :2] += spread_m**2 * normal[:, :, None] * normal[:, None, :]
        return (np.concatenate([states, self.off_mean[None]]), np.concatenate([covs, self.off_cov[None]]),
                np.exp(np.append(self.log_weight, self.off_log_weight)))

    def points(self, graph: RoadGraph, abscissae: NDArray[np.float64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each road component as points ``s = m_s + sigma_s a`` along its edge, clipped to it (equal shares of its
        weight), and the off-road mean: states (len(a) C + 1, 4) and weights."""
        q = len(abscissae)
        s = self.mean[:, 0:1] + np.sqrt(self.cov[:, 0, 0])[:, None] * abscissae
        s = np.clip(s, 0.0, graph.length[self.edge][:, None])  # the component's mass is on its edge
        edges = np.repeat(self.edge[:, None], q, axis=1)
        xy = graph.position(edges, s).reshape(-1, 2)
        v = (self.mean[:, 1:2, None] * graph.direction[self.edge][:, None, :]).repeat(q, axis=1).reshape(-1, 2)
        weights = np.repeat(np.exp(self.log_weight) / q, q)
        return (np.concatenate([np.concatenate([xy, v], axis=1), self.off_mean[None]]),
                np.append(weights, np.exp(self.off_log_weight)))


def _truncated(mean: NDArray[np.float64], cov: NDArray[np.float64], limit: NDArray[np.float64], above: bool,
               axis: int = 0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Moments of (s, v) given ``s > limit`` (``above``) or ``s < limit`` (module docstring); ``axis = 1``
    truncates the speed instead, and the arc length follows by its regression."""
    if axis == 1:
        swap = [1, 0]
        m, p = _truncated(mean[:, swap], cov[:, swap][:, :, swap], limit, above)
        return m[:, swap], p[:, swap][:, :, swap]
    mu, var = mean[:, 0], cov[:, 0, 0]
    sigma = np.sqrt(var)
    a = (limit - mu) / sigma
    pdf = _INV_SQRT_2PI * np.exp(-0.5 * a * a)
    if above:
        lam = pdf / np.maximum(ndtr(-a), 1e-300)
        s_mean, s_var = mu + sigma * lam, var * (1.0 + a * lam - lam * lam)
    else:
        lam = pdf / np.maximum(ndtr(a), 1e-300)
        s_mean, s_var = mu - sigma * lam, var * (1.0 - a * lam - lam * lam)
    s_var = np.maximum(s_var, 1e-6)
    beta = cov[:, 0, 1] / var
    new_mean = np.stack([s_mean, mean[:, 1] + beta * (s_mean - mu)], axis=1)
    new_cov = np.empty_like(cov)
    new_cov[:, 0, 0] = s_var
    new_cov[:, 0, 1] = new_cov[:, 1, 0] = beta * s_var
    new_cov[:, 1, 1] = np.maximum(cov[:, 1, 1] - beta * cov[:, 0, 1] + beta * beta * s_var, 1e-6)
    return new_mean, new_cov


def forward_only(mean: NDArray[np.float64], cov: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each component conditioned on ``v >= 0`` and then ``s >= 0`` where it has more than ``SPLIT_MIN`` of
    its mass outside: a car drives its edge forwards (one turning round is on the reverse edge), and the
    mass before the start of an edge is the car not yet past its last node."""
    mean, cov = mean.copy(), cov.copy()
    for axis in (1, 0):
        outside = ndtr(-mean[:, axis] / np.sqrt(cov[:, axis, axis])) > SPLIT_MIN
        if outside.any():
            mean[outside], cov[outside] = _truncated(mean[outside], cov[outside], np.zeros(int(outside.sum())),
                                                     above=True, axis=axis)
    return mean, cov


def branch(graph: RoadGraph, table: NDArray[np.float64], edge: NDArray[np.intp], mean: NDArray[np.float64],
           cov: NDArray[np.float64], log_w: NDArray[np.float64]
           ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Split every component's mass beyond the end of its edge onto the successors (:mod:`gcs.core.roads.mixture`)."""
    done: list[tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]] = [
        (edge, mean, cov, log_w)]
    pending = (edge, mean, cov, log_w)
    for _ in range(MAX_PASSES):
        e, m, p, w = pending
        length = graph.length[e]
        beyond = ndtr((m[:, 0] - length) / np.sqrt(p[:, 0, 0]))
        whole, part = beyond > 1.0 - SPLIT_MIN, (beyond >= SPLIT_MIN) & (beyond <= 1.0 - SPLIT_MIN)
        moving = whole | part
        if not moving.any():
            break
        done[-1] = (e[~moving], m[~moving], p[~moving], w[~moving])
        stay_m, stay_p = _truncated(m[part], p[part], length[part], above=False)
        done.append((e[part], stay_m, stay_p, w[part] + np.log(1.0 - beyond[part])))
        go_m, go_p = m[moving].copy(), p[moving].copy()
        go_w = w[moving].copy()
        if part.any():
            cut = part[moving]
            go_m[cut], go_p[cut] = _truncated(m[part], p[part], length[part], above=True)
            go_w[cut] += np.log(beyond[part])
        go_m[:, 0] -= length[moving]
        rows, cols = np.nonzero(table[e[moving]] > 0.0)
        pending = (graph.successors[e[moving][rows], cols], go_m[rows], go_p[rows],
                   go_w[rows] + np.log(table[e[moving][rows], cols]))
        done.append(pending)
    edges, means, covs, weights = (np.concatenate(parts) for parts in zip(*done))
    return edges, means, covs, weights


def merge_and_prune(comp: RoadComponents, max_components: int, prune_weight: float) -> RoadComponents:
    """Merge close components of an edge, drop light ones, keep the heaviest ``max_components``; renormalise.

    Greedy from the heaviest: each unmerged component takes every lighter unmerged one of its edge within
    ``MERGE_D2`` of it (in its own metric); each group is moment-matched (vectorised over the groups).
    """
    order = np.argsort(-comp.log_weight)
    order = order[np.exp(comp.log_weight[order]) >= prune_weight]
    edge, mean, cov, log_w = comp.edge[order], comp.mean[order], comp.cov[order], comp.log_weight[order]
    n = len(order)
    det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] ** 2
    d = mean[None, :, :] - mean[:, None, :]  # d[i, j] = m_j - m_i
    d2 = (cov[:, None, 1, 1] * d[..., 0] ** 2 - 2.0 * cov[:, None, 0, 1] * d[..., 0] * d[..., 1]
          + cov[:, None, 0, 0] * d[..., 1] ** 2) / det[:, None]
    close = (edge[:, None] == edge[None, :]) & (d2 < MERGE_D2)
    label = np.full(n, -1)
    groups = 0
    for i in range(n):
        if label[i] < 0:
            label[close[i] & (label < 0)] = groups
            label[i] = groups
            groups += 1
            if groups == max_components:
                break
    kept = label >= 0
    label, w = label[kept], np.exp(log_w[kept])
    total_w = np.bincount(label, weights=w, minlength=groups)
    share = w / total_w[label]
    new_mean = np.zeros((groups, 2))
    np.add.at(new_mean, label, share[:, None] * mean[kept])
    spread = mean[kept] - new_mean[label]
    new_cov = np.zeros((groups, 2, 2))
    np.add.at(new_cov, label, share[:, None, None] * (cov[kept] + spread[:, :, None] * spread[:, None, :]))
    first = np.zeros(groups, dtype=np.intp)
    first[label[::-1]] = np.flatnonzero(kept)[::-1]
    with np.errstate(divide="ignore"):
        log_total = np.log(total_w)
    total = np.logaddexp(np.logaddexp.reduce(log_total) if groups else -np.inf, comp.off_log_weight)
    return RoadComponents(edge[first], new_mean, new_cov, log_total - total, comp.off_mean, comp.off_cov,
                          comp.off_log_weight - total)


def road_summary(graph: RoadGraph, edge: NDArray[np.intp], mean: NDArray[np.float64], cov: NDArray[np.float64],
                 weights: NDArray[np.float64],
                 spread_m: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The moment-matched ``[x, y, vx, vy]`` Gaussian of the road components alone."""
    road = RoadComponents(edge, mean, cov, np.log(np.maximum(weights, 1e-300)), np.zeros(4), np.eye(4), -np.inf)
    states, covs, w = road.enu(graph, spread_m)
    return moment_match(w[:-1] / w[:-1].sum(), states[:-1], covs[:-1])


def start_components(graph: RoadGraph, initial: GaussianEstimate, off_road: float, spread_m: float,
                     rng: np.random.Generator) -> RoadComponents:
    """A new track: draws of ``initial`` snapped to the roads; per edge reached, one component each way, weighted
    by the draws on it and by how many of them move that way; the off-road mode is ``initial`` itself."""
    draws = rng.multivariate_normal(initial.mean[:4], initial.cov[:4, :4], size=START_SAMPLES)
    edge, s, _ = graph.snap(draws[:, :2])
    edges, means, covs, weights = [], [], [], []
    for e in np.unique(edge):
        on = edge == e
        for directed, s_on, velocity in ((e, s[on], draws[on, 2:4]),
                                         (graph.reverse[e], graph.length[e] - s[on], draws[on, 2:4])):
            if directed < 0:
                continue
            along = velocity @ graph.direction[directed]
            share = (np.sum(along > 0.0) + 0.5) / (len(along) + 1.0)
            speed = np.abs(along)
            edges.append(directed)
            means.append([s_on.mean(), speed.mean()])
            covs.append(np.diag([s_on.var() + spread_m**2, max(speed.var(), 4.0)]))
            weights.append(on.mean() * share)
    w = np.array(weights) / np.sum(weights) * (1.0 - off_road)
    with np.errstate(divide="ignore"):
        return RoadComponents(np.array(edges, dtype=np.intp), np.array(means), np.array(covs), np.log(w),
                              initial.mean[:4].copy(), initial.cov[:4, :4].copy(), float(np.log(off_road)))
