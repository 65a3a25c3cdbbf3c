"""Route segments, the map observation of feng2019 eq. (2)-(3), and the modes' transition matrix.

A route is a polyline in ENU metres (the stored route of a map database, or the
vehicle's recent commanded path); its segments are the switch states of the
navigation filter. Each segment has an integer ``key``: its index along the
route, so that consecutive segments have consecutive keys.

Map observation of segment ``seg_i`` (eq. 2):

.. math::
    Y_{map}^{seg_i} = [x_{map}, y_{map}, \\theta_{map}]^T = [I_3\\ 0] X + \\beta_{map}

where ``(x_map, y_map)`` is the perpendicular projection of the mode's predicted
position onto the segment (clamped to its ends) and ``theta_map`` the
segment's heading. Its covariance, eq. (3), is the error ellipse of the
segment: ``delta_along`` along it, ``delta_across`` across it (the ``Q_xy``
term is the rotation of that ellipse into ENU) and ``delta_theta`` on the heading:

.. math::
    Q^{map} = \\begin{bmatrix} R_\\psi\\, \\mathrm{diag}(\\delta_{along}^2, \\delta_{across}^2)\\, R_\\psi^T & 0 \\\\
                              0 & \\delta_\\theta^2 \\end{bmatrix}

Inside the segment the along-track innovation is zero by construction, so the
along-track term only matters beyond its ends; ``delta_along`` should be of the
order of the segment's length (the paper's "observation length"), since every
update with it also shrinks the along-track variance a little.

Off-route mode. Besides one mode per candidate segment the navigation filter
keeps an *off-route* mode (key :data:`OFF_ROUTE`) with no map observation, so
that a vehicle off every candidate segment (or with none nearby) keeps a sane
estimate. :func:`transition_matrix` gives the row-stochastic ``C[i, j]`` from the
previous modes' keys to the new ones (:class:`TransitionModel`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gcs.core.filters.kalman import Observation
from gcs.core.filters.switching import check_transition
from gcs.core.navigation.model import STATE_DIM, THETA, X, Y

__all__ = ["OFF_ROUTE", "RouteSegment", "route_segments", "candidate_segments", "map_observation",
           "TransitionModel", "transition_matrix"]

OFF_ROUTE = -1
"""Key of the off-route mode (no map observation). Segment keys are >= 0."""

_H_MAP = np.zeros((3, STATE_DIM))
_H_MAP[0, X] = _H_MAP[1, Y] = _H_MAP[2, THETA] = 1.0


@dataclass(frozen=True)
class RouteSegment:
    """One straight piece of a route from ``start`` to ``end`` (ENU metres), with its ``key`` (>= 0)."""

    key: int
    start: tuple[float, float]
    end: tuple[float, float]

    def __post_init__(self) -> None:
        if self.key < 0:
            raise ValueError(f"segment keys are >= 0 (got {self.key}); {OFF_ROUTE} is the off-route mode")
        if self.length_m <= 0.0:
            raise ValueError(f"segment {self.key} has zero length")

    @property
    def length_m(self) -> float:
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    @property
    def heading_rad(self) -> float:
        """ENU heading from ``start`` to ``end`` (``theta_map`` of eq. 2)."""
        return math.atan2(self.end[1] - self.start[1], self.end[0] - self.start[0])

    def project(self, xy: ArrayLike) -> tuple[NDArray[np.float64], float]:
        """The closest point of the segment to ``xy`` (2,) and the distance to it, metres."""
        p = np.asarray(xy, dtype=np.float64)
        a, b = np.asarray(self.start), np.asarray(self.end)
        d = b - a
        t = min(max(float((p - a) @ d) / float(d @ d), 0.0), 1.0)
        closest = a + t * d
        return closest, float(np.hypot(*(p - closest)))


def route_segments(path_xy: ArrayLike, first_key: int = 0) -> tuple[RouteSegment, ...]:
    """The segments of a polyline (P, 2), keyed ``first_key``, ``first_key + 1``, ... (repeated points skipped)."""
    points = np.asarray(path_xy, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"a route is a (P, 2) polyline, got shape {points.shape}")
    segments = []
    key = first_key
    for a, b in zip(points[:-1], points[1:]):
        if math.hypot(*(b - a)) > 1e-9:
            segments.append(RouteSegment(key, (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))))
        key += 1
    return tuple(segments)


def candidate_segments(segments: Sequence[RouteSegment], xy: ArrayLike, radius_m: float,
                       max_count: int) -> tuple[RouteSegment, ...]:
    """The segments within ``radius_m`` of ``xy``, nearest first, at most ``max_count``, in key order."""
    if not segments or max_count == 0:
        return ()
    p = np.asarray(xy, dtype=np.float64)
    starts = np.array([s.start for s in segments])
    steps = np.array([s.end for s in segments]) - starts
    t = np.clip(np.einsum("ki,ki->k", p - starts, steps) / np.einsum("ki,ki->k", steps, steps), 0.0, 1.0)
    distance = np.hypot(*(p - starts - t[:, None] * steps).T)
    order = sorted((float(d), s.key, k) for k, (d, s) in enumerate(zip(distance, segments)) if d <= radius_m)
    return tuple(sorted((segments[k] for _, _, k in order[:max_count]), key=lambda s: s.key))


def map_observation(segment: RouteSegment, predicted_xy: ArrayLike, along_std_m: float, across_std_m: float,
                    heading_std_rad: float, placement_cov: NDArray[np.float64] | None = None) -> Observation:
    """Eq. (2) for ``segment`` about the mode's predicted position, with the covariance of eq. (3).

    ``placement_cov`` (3, 3), the covariance of the route's own position and heading
    ``(x, y, theta)``, is added to eq. (3)'s: a commanded path laid out from where the
    vehicle *believed* it was is only as well placed as that belief (:func:`nav_update`'s
    ``route_cov``); a surveyed map has none.
    """
    closest, _ = segment.project(predicted_xy)
    psi = segment.heading_rad
    rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
    r = np.zeros((3, 3))
    r[:2, :2] = rot @ np.diag([along_std_m**2, across_std_m**2]) @ rot.T  # eq. (3): delta_x^2, Q_xy, delta_y^2
    r[2, 2] = heading_std_rad**2
    if placement_cov is not None:
        r = r + placement_cov
    return Observation(np.array([closest[0], closest[1], psi]), _H_MAP, 0.5 * (r + r.T), angle_rows=(2,))


@dataclass(frozen=True)
class TransitionModel:
    """How the vehicle moves between modes from one update to the next.

    From a segment: to the off-route mode with ``leave_route``; the rest is shared
    among the new candidate segments in proportion to ``stay`` (same key),
    ``advance`` (the next key) and ``jump`` (any other key). From the off-route
    mode: stay off with ``stay_off_route``, the rest shared equally among the
    candidates. Without candidates every mode goes off-route.
    """

    leave_route: float = 0.02
    stay_off_route: float = 0.9
    stay: float = 1.0
    advance: float = 1.0
    jump: float = 0.05

    def __post_init__(self) -> None:
        if not (0.0 <= self.leave_route <= 1.0 and 0.0 <= self.stay_off_route <= 1.0):
            raise ValueError("leave_route and stay_off_route are probabilities")
        if min(self.stay, self.advance, self.jump) < 0.0 or max(self.stay, self.advance, self.jump) <= 0.0:
            raise ValueError("stay, advance and jump are non-negative weights, not all zero")


def transition_matrix(previous: Sequence[int], new: Sequence[int], model: TransitionModel) -> NDArray[np.float64]:
    """Row-stochastic ``C[i, j] = P(mode new[j] now | mode previous[i] before)`` over mode keys.

    ``new`` must contain :data:`OFF_ROUTE`; segment keys are >= 0.
    """
    assert OFF_ROUTE in new, "the new modes must include the off-route mode"
    segment_columns = [j for j, key in enumerate(new) if key != OFF_ROUTE]
    off = list(new).index(OFF_ROUTE)
    c = np.zeros((len(previous), len(new)))
    for i, source in enumerate(previous):
        if not segment_columns:
            c[i, off] = 1.0
            continue
        if source == OFF_ROUTE:
            c[i, off] = model.stay_off_route
            c[i, segment_columns] = (1.0 - model.stay_off_route) / len(segment_columns)
            continue
        weights = np.array([model.stay if new[j] == source else model.advance if new[j] == source + 1 else model.jump
                            for j in segment_columns])
        if weights.sum() <= 0.0:
            weights = np.ones(len(segment_columns))
        c[i, off] = model.leave_route
        c[i, segment_columns] = (1.0 - model.leave_route) * weights / weights.sum()
    return check_transition(c, len(previous), len(new))
