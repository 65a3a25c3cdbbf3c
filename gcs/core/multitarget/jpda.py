"""Joint probabilistic data association (JPDA) of one vehicle's detections, by exact enumeration per cluster.

Fortmann, Bar-Shalom & Scheffe (1983); Bar-Shalom & Fortmann (1988) and
Bar-Shalom, Willett & Tian (2011), the JPDA chapters; the "parametric" form with
Poisson clutter of spatial density ``lambda``.

Clusters. Tracks and detections are the nodes of a bipartite graph with an edge
wherever the gate validates the pair; its connected components are independent
association problems (Blackman & Popoli 1999, clustering). A track without
validated detections is missed for certain (``beta_t0 = 1``).

Joint events. A feasible event ``theta`` gives each track of a cluster at most
one of its validated detections and each detection at most one track; the rest
are clutter. Its posterior probability is

.. math::
    P(\\theta \\mid Z) \\propto \\prod_{t \\text{ detected}}
        \\frac{P_D \\, \\mathcal N(\\nu_{t\\theta(t)}; 0, S_{t\\theta(t)})}{\\lambda}
        \\prod_{t \\text{ missed}} (1 - P_D P_G)
    \\;\\propto\\; \\exp\\Big(-\\sum_{t \\text{ detected}} c_{t\\theta(t)}\\Big)

with ``c`` the GNN cost of :func:`gcs.core.multitarget.gnn.assignment_costs`
(dividing by ``(1 - P_D P_G)`` for every track is common to all events). The
marginal association probabilities are

.. math::
    \\beta_{tj} = \\sum_{\\theta: \\theta(t) = j} P(\\theta \\mid Z), \\qquad
    \\beta_{t0} = 1 - \\sum_j \\beta_{tj}

and the update with them is :func:`gcs.core.multitarget.filter.mixture_contributions`.

Cap. The events of a cluster are enumerated as the feasible members of the
product of each track's options (``-1`` and its validated detections); when that
product exceeds ``max_hypotheses`` the cluster is not enumerated: it is
associated by GNN instead (``beta`` one-hot on the best assignment, computed on
the cluster alone) and counted in :attr:`JpdaResult.clusters_over_cap`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from gcs.core.multitarget.gnn import gnn_assign

__all__ = ["JpdaResult", "clusters", "joint_events", "jpda_marginals"]

DEFAULT_MAX_HYPOTHESES = 20_000
"""Default cap on the product of the tracks' option counts in one cluster."""


@dataclass(frozen=True)
class JpdaResult:
    """Marginal association probabilities of one vehicle's detections, and what the clustering did.

    ``beta`` is (T, n), ``beta[t, j] = P(detection j is track t's)``; ``1 - beta.sum(1)``
    is each track's probability of no detection.
    """

    beta: NDArray[np.float64]
    clusters: int
    clusters_over_cap: int


def clusters(valid: NDArray[np.bool_]) -> list[tuple[NDArray[np.int64], NDArray[np.int64]]]:
    """Connected components (tracks, detections) of the validation graph that hold at least one edge."""
    t_count, n_count = valid.shape
    rows, cols = np.nonzero(valid)
    if rows.size == 0:
        return []
    graph = coo_matrix((np.ones(rows.size), (rows, t_count + cols)), shape=(t_count + n_count,) * 2)
    _, labels = connected_components(graph, directed=False)
    found = []
    for label in np.unique(labels[rows]):
        tracks = np.flatnonzero(labels[:t_count] == label)
        detections = np.flatnonzero(labels[t_count:] == label)
        found.append((tracks, detections))
    return found


def joint_events(valid: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Every feasible joint event of a cluster, shape (E, T): the detection of each track, -1 for none.

    ``valid`` (T, n) is the cluster's validation matrix.
    """
    options = [[-1, *np.flatnonzero(row).tolist()] for row in valid]
    events = np.array(list(itertools.product(*options)), dtype=np.int64).reshape(-1, len(options))
    feasible = np.ones(events.shape[0], dtype=bool)
    for a, b in itertools.combinations(range(events.shape[1]), 2):
        feasible &= (events[:, a] < 0) | (events[:, a] != events[:, b])
    return events[feasible]


def _cluster_marginals(costs: NDArray[np.float64], valid: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``beta`` (T, n) of one cluster by enumeration: ``P(theta) ∝ exp(-sum c)`` over its feasible events."""
    events = joint_events(valid)
    t_count, n_count = costs.shape
    padded = np.hstack([costs, np.zeros((t_count, 1))])  # column n: missed, cost 0
    chosen = np.where(events < 0, n_count, events)
    log_w = -padded[np.arange(t_count)[None, :], chosen].sum(axis=1)
    w = np.exp(log_w - log_w.max())
    w /= w.sum()
    beta = np.zeros((t_count, n_count + 1))
    np.add.at(beta, (np.broadcast_to(np.arange(t_count), events.shape), chosen), w[:, None])
    return beta[:, :n_count]


def jpda_marginals(costs: NDArray[np.float64], valid: NDArray[np.bool_],
                   max_hypotheses: int = DEFAULT_MAX_HYPOTHESES) -> JpdaResult:
    """Marginal association probabilities of every track and detection of one vehicle.

    Parameters
    ----------
    costs : ndarray, shape (T, n)
        ``c_tj`` of :func:`gcs.core.multitarget.gnn.assignment_costs` (``+inf`` outside the gate).
    valid : ndarray of bool, shape (T, n)
        The gate.
    max_hypotheses : int
        Cap on the product of option counts of a cluster's tracks (see the module's docstring).
    """
    t_count, n_count = costs.shape
    beta = np.zeros((t_count, n_count))
    found = clusters(valid)
    over = 0
    for tracks, detections in found:
        sub_valid = valid[np.ix_(tracks, detections)]
        sub_costs = costs[np.ix_(tracks, detections)]
        options = math.prod(int(k) + 1 for k in sub_valid.sum(axis=1))
        if options > max_hypotheses:
            over += 1
            chosen = gnn_assign(sub_costs)
            hit = chosen >= 0
            beta[tracks[hit], detections[chosen[hit]]] = 1.0
            continue
        beta[np.ix_(tracks, detections)] = _cluster_marginals(sub_costs, sub_valid)
    return JpdaResult(beta, len(found), over)
