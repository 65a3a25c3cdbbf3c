"""A car that drives a road graph: the truth of a street-driving target in a city with declared roads.

:class:`RoadTarget` drives a :class:`gcs.core.roads.RoadGraph` (a real city's
streets, any GeoJSON roads) at a constant cruising speed ``v``. Its state is an
edge ``e`` and the arc length ``s`` along it (:class:`RoadTargetState`); the
position is the graph's ``p(e, s) = n_tail(e) + s d_e`` and the velocity ``v d_e``.
A step of ``dt`` drives ``v dt`` metres: past the end of ``e`` the car enters one
of ``e``'s successors (the graph's edges leaving its head node, no U-turn unless
it is a dead end), chosen as the street grid's car chooses
(:class:`sim_vehicles.truth.target.StreetTarget`): where one successor goes
straight on (turn cosine above :data:`gcs.core.roads.graph.STRAIGHT_COS`) the car
takes it with probability ``1 - turn_probability``, and otherwise picks
uniformly among all the ways on. At the end of a one-way road that leads nowhere
the car stops there.

The choice is the simulator's own: it does not use the trackers' branch table.
Pure: state in, ``numpy.random.Generator`` in, new state out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from gcs.core.roads.graph import STRAIGHT_COS, RoadGraph
from sim_vehicles.truth.target_state import TargetState

__all__ = ["RoadTarget", "RoadTargetState"]


@dataclass(frozen=True)
class RoadTargetState(TargetState):
    """A :class:`TargetState` on the graph: ``edge`` (directed edge index) and ``s_m`` (metres along it)."""

    edge: int = -1
    s_m: float = 0.0


@dataclass(frozen=True, eq=False)
class RoadTarget:
    """Drives ``graph`` at ``speed_mps``, turning at junctions with ``turn_probability`` (module docstring)."""

    graph: RoadGraph
    speed_mps: float = 10.0
    turn_probability: float = 0.5

    def start(self, near_xy: ArrayLike, rng: np.random.Generator) -> RoadTargetState:
        """On the road point nearest ``near_xy``, driving either way along it (a draw from ``rng``) where the
        road is two-way."""
        edge, s, _ = self.graph.snap(np.asarray(near_xy, dtype=np.float64)[None])
        e, along = int(edge[0]), float(s[0])
        reverse = int(self.graph.reverse[e])
        if reverse >= 0 and rng.random() < 0.5:
            e, along = reverse, float(self.graph.length[reverse]) - along
        return self._state(e, along, 0.0, moving=True)

    def step(self, state: TargetState, dt: float, rng: np.random.Generator) -> RoadTargetState:
        """Drive ``dt`` seconds, choosing a way on at every node passed; from a :class:`RoadTargetState`
        (:meth:`start`'s), TypeError for any other."""
        if not isinstance(state, RoadTargetState):
            raise TypeError(f"a road target drives on from a RoadTargetState, not a {type(state).__name__}")
        e, s = state.edge, state.s_m
        if not np.any(state.velocity):  # stopped at the end of a one-way road
            return self._state(e, s, state.elapsed_s + dt, moving=False)
        remaining = self.speed_mps * dt
        while s + remaining > self.graph.length[e]:
            nxt = self._choose(e, rng)
            if nxt == e:  # a one-way road that leads nowhere: stop at its end
                return self._state(e, float(self.graph.length[e]), state.elapsed_s + dt, moving=False)
            remaining -= float(self.graph.length[e]) - s
            e, s = nxt, 0.0
        return self._state(e, s + remaining, state.elapsed_s + dt, moving=True)

    def _choose(self, edge: int, rng: np.random.Generator) -> int:
        """The edge taken at the end of ``edge``."""
        options = self.graph.successors[edge]
        valid = options >= 0
        options, cosines = options[valid], self.graph.turn_cos[edge][valid]
        if len(options) == 1:
            return int(options[0])
        straight = cosines > STRAIGHT_COS
        if straight.any() and rng.random() >= self.turn_probability:
            return int(options[np.argmax(cosines)])
        return int(options[rng.integers(len(options))])

    def _state(self, edge: int, s: float, elapsed_s: float, moving: bool) -> RoadTargetState:
        position = self.graph.position(edge, s)
        velocity = self.graph.direction[edge] * (self.speed_mps if moving else 0.0)
        return RoadTargetState(position, velocity, elapsed_s, edge, s)
