"""One name per target across a federation: how a member names its own tracks.

Every member names each of its confirmed tracks with a **global id**, and every member decides
alone, from what the others publish; the rules make them agree:

1. A track keeps its name for as long as it lives.
2. A new track takes the name of the nearest target the federation already knows (a track another
   member holds, or a target lost by all and still searched for) whose position gates with it: the
   squared Mahalanobis distance of the positions, under the sum of their covariances, below the
   chi-square quantile :data:`ADOPT_PROBABILITY` (2 degrees of freedom). This is how a car keeps its
   id when it drives from one team's area into the next, or when a member that died is replaced.
3. Otherwise it gets a new name, ``<member>-t<local id>-<second of its birth>``, born at the track's stamp: a
   member restarted, whose local ids start again at 1, never gives a name a second time.
4. When two members named one car at once, each sees the other's track gate with its own within
   the tighter :data:`RENAME_PROBABILITY`; the one holding the younger name (later ``born_ns``, then
   the larger id) takes the older. Both end with the older name, and the renaming is counted as an
   id change.

5. A name can end on two cars (named together while the cars drove together, before they
   parted). The holder with the smallest member id keeps it, and so does every holder whose track
   gates with that holder's track of the name (chi-square :data:`SPLIT_PROBABILITY`); another holder
   gives the name up, and its track is named again by rules 2 and 3, the name it gave up excepted.
   The change is counted.

No two own tracks carry one name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.core.multitarget.gating import gate_threshold

__all__ = ["ADOPT_PROBABILITY", "RENAME_PROBABILITY", "SPLIT_PROBABILITY", "GlobalName", "HolderTrack", "KnownTarget",
           "GlobalNames", "older", "position_distance2"]

NS_PER_S = 1_000_000_000
ADOPT_PROBABILITY = 0.999
RENAME_PROBABILITY = 0.99
SPLIT_PROBABILITY = 0.9999


@dataclass(frozen=True)
class GlobalName:
    """A global id and when it was first given (ns)."""

    global_id: str
    born_ns: int


@dataclass(frozen=True)
class HolderTrack:
    """Another member's track on a name, at the naming stamp: the member, position (2,), covariance (2, 2)."""

    member_id: str
    position: NDArray[np.float64]
    position_cov: NDArray[np.float64]


@dataclass(frozen=True)
class KnownTarget:
    """A target the federation knows apart from this member's own tracks, at the naming stamp: its name,
    position (2,) and position covariance (2, 2); ``held`` when another member holds a track on it (else
    it is lost and searched for), and then each holder's own track."""

    name: GlobalName
    position: NDArray[np.float64]
    position_cov: NDArray[np.float64]
    held: bool
    holders: tuple[HolderTrack, ...] = ()


def older(a: GlobalName, b: GlobalName) -> bool:
    """Whether name ``a`` wins over ``b`` (rule 4): born earlier, or born at once with the smaller id."""
    return (a.born_ns, a.global_id) < (b.born_ns, b.global_id)


def position_distance2(a: NDArray[np.float64], a_cov: NDArray[np.float64], b: NDArray[np.float64],
                       b_cov: NDArray[np.float64]) -> float:
    """The squared Mahalanobis distance of two positions (2,) under the sum of their covariances (2, 2)."""
    delta = a - b
    return float(delta @ np.linalg.solve(a_cov + b_cov, delta))


def _distance2(position: NDArray[np.float64], cov: NDArray[np.float64], known: KnownTarget) -> float:
    return position_distance2(position, cov, known.position, known.position_cov)


class GlobalNames:
    """A member's names for its own tracks (module docstring); :attr:`changes` counts the renamings."""

    def __init__(self, member_id: str) -> None:
        self.member_id = member_id
        self.names: dict[int, GlobalName] = {}
        self.changes = 0
        self._adopt = gate_threshold(ADOPT_PROBABILITY, 2)
        self._rename = gate_threshold(RENAME_PROBABILITY, 2)
        self._split = gate_threshold(SPLIT_PROBABILITY, 2)

    def assign(self, stamp_ns: int, ids: Sequence[int], positions: NDArray[np.float64],
               position_covs: NDArray[np.float64], known: Sequence[KnownTarget]) -> dict[int, GlobalName]:
        """Name the own tracks ``ids`` (positions (T, 2), covariances (T, 2, 2), at ``stamp_ns``) against the targets
        ``known``; every own track's name by its id."""
        rows = {int(track_id): row for row, track_id in enumerate(ids)}
        self.names = {track_id: name for track_id, name in self.names.items() if track_id in rows}
        given_up: dict[int, str] = {}
        for track_id, name in sorted(self.names.items()):
            row = rows[track_id]
            if self._on_another_car(name, positions[row], position_covs[row], known):
                given_up[track_id] = name.global_id
                del self.names[track_id]
                self.changes += 1
            else:
                self._rename_if_younger(track_id, name, positions[row], position_covs[row], known)
        carried = {name.global_id for name in self.names.values()}
        pairs = []
        for track_id in sorted(set(rows) - set(self.names)):
            row = rows[track_id]
            for index, target in enumerate(known):
                if target.name.global_id not in carried and target.name.global_id != given_up.get(track_id):
                    d2 = _distance2(positions[row], position_covs[row], target)
                    if d2 < self._adopt:
                        pairs.append((d2, track_id, index))
        for _, track_id, index in sorted(pairs):
            name = known[index].name
            if track_id not in self.names and name.global_id not in carried:
                self.names[track_id] = name
                carried.add(name.global_id)
        for track_id in sorted(set(rows) - set(self.names)):  # rule 3 (a given-up name's track is new here too)
            self.names[track_id] = GlobalName(f"{self.member_id}-t{track_id}-{stamp_ns // NS_PER_S}", stamp_ns)
        return dict(self.names)

    def _on_another_car(self, name: GlobalName, position: NDArray[np.float64], cov: NDArray[np.float64],
                        known: Sequence[KnownTarget]) -> bool:
        """Rule 5: whether the own track named ``name`` must give it up (another holder keeps it on another car)."""
        holders = next((t.holders for t in known if t.held and t.name.global_id == name.global_id), ())
        if not holders:
            return False
        first = min(holders, key=lambda h: h.member_id)
        if first.member_id > self.member_id:
            return False
        return position_distance2(position, cov, first.position, first.position_cov) > self._split

    def _rename_if_younger(self, track_id: int, name: GlobalName, position: NDArray[np.float64],
                           cov: NDArray[np.float64], known: Sequence[KnownTarget]) -> None:
        carried = {n.global_id for t, n in self.names.items() if t != track_id}
        best: tuple[float, GlobalName] | None = None
        for target in known:
            other = target.name
            if (target.held and other.global_id != name.global_id and other.global_id not in carried
                    and older(other, name)):
                d2 = _distance2(position, cov, target)
                if d2 < self._rename and (best is None or d2 < best[0]):
                    best = (d2, other)
        if best is not None:
            self.names[track_id] = best[1]
            self.changes += 1
