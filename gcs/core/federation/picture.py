"""A member's picture of the whole federation: every target once, by its global id.

:class:`FederatedPicture` keeps what the other members published last (their
:class:`~protocols.federation.MemberTracks`) and, at each of its own decision steps, makes the
picture of that stamp:

* the other members' tracks predicted to the stamp (:func:`~gcs.core.federation.fusion.predict_to`);
* the member's own confirmed tracks named (:class:`~gcs.core.federation.global_ids.GlobalNames`);
* every global id's tracks, own and others', fused by the federation's rule (covariance intersection
  by default, :mod:`gcs.core.federation.fusion`): a :class:`GlobalTarget` each;
* the **lost** targets: a global id that some member held and none holds any more (its holder deleted
  the track, or died) is kept, predicted on, and searched for until :attr:`FederatedPicture.forget_s`
  after its last detection; it is no longer lost once a member names a track after it. A global id
  that went because its holder took an older name for the same car (its last estimate gates with a
  target held now) is not lost.

A member whose liveliness token is withdrawn, or that has published nothing for :data:`SILENT_S`,
is gone: its tracks leave the picture at once and their targets become lost targets, for the others
to take up.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gcs.core.federation.fusion import FusionRule, covariance_intersection, predict_to
from gcs.core.federation.global_ids import GlobalName, GlobalNames, HolderTrack, KnownTarget, position_distance2
from gcs.core.models.motion import LinearMotionModel
from gcs.core.multitarget.gating import gate_threshold
from protocols.federation import MemberTracks

__all__ = ["SILENT_S", "GlobalTarget", "OwnTracks", "Picture", "FederatedPicture"]

NS_PER_S = 1_000_000_000
SILENT_S = 3.0
"""A member that has published nothing for this long (data time) is taken as gone, token or not."""
RECENT_DETECTION_S = 2.0
"""A holder whose newest detection of a target is this close to the newest of all has it in sight (others' messages
arrive a step late, so their detections look one step older than the member's own)."""
MERGED_PROBABILITY = 0.999
"""A global id that is no longer held, whose last estimate gates with a target held now (2 degrees of freedom), was
renamed to it (:mod:`~gcs.core.federation.global_ids`, rule 4), not lost."""


@dataclass(frozen=True)
class OwnTracks:
    """A member's confirmed tracks at one stamp: ids (T,), means (T, 4), covariances (T, 4, 4), and the stamp of
    each one's newest detection (T,)."""

    ids: NDArray[np.int64]
    means: NDArray[np.float64]
    covs: NDArray[np.float64]
    detected_ns: NDArray[np.int64]

    @classmethod
    def none(cls) -> OwnTracks:
        return cls(np.zeros(0, dtype=np.int64), np.zeros((0, 4)), np.zeros((0, 4, 4)), np.zeros(0, dtype=np.int64))


@dataclass(frozen=True)
class GlobalTarget:
    """One target of the picture: its name, fused (or, lost, predicted) estimate, the members holding a track on it
    (empty when lost), the newest detection's stamp, and the holders that have it in sight (their newest detection
    within :data:`RECENT_DETECTION_S` of that)."""

    name: GlobalName
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    holders: tuple[str, ...]
    detected_ns: int
    detected_by: tuple[str, ...] = ()


@dataclass(frozen=True)
class Picture:
    """The picture at ``stamp_ns``: the targets held (by global id), the lost ones, and the own tracks' names."""

    stamp_ns: int
    targets: tuple[GlobalTarget, ...]
    lost: tuple[GlobalTarget, ...]
    own_names: Mapping[int, GlobalName]


@dataclass(frozen=True)
class _Held:
    """One member's track on a global id, at the picture's stamp."""

    member: str
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    detected_ns: int
    name: GlobalName


@dataclass
class _Lost:
    name: GlobalName
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    stamp_ns: int
    detected_ns: int


@dataclass
class FederatedPicture:
    """One member's picture of the federation (module docstring)."""

    member_id: str
    motion: LinearMotionModel
    fusion: FusionRule = covariance_intersection
    forget_s: float = 90.0
    members: dict[str, MemberTracks] = field(default_factory=dict)
    """The newest message of each other member present."""
    names: GlobalNames = field(init=False)
    _lost: dict[str, _Lost] = field(default_factory=dict)
    _held: dict[str, GlobalTarget] = field(default_factory=dict)
    _held_stamp_ns: int = 0

    def __post_init__(self) -> None:
        self.names = GlobalNames(self.member_id)
        self._merge_gate = gate_threshold(MERGED_PROBABILITY, 2)

    def heard(self, message: MemberTracks) -> bool:
        """Take another member's message; False (ignored) when it is this member's own or older than the one held."""
        if message.member_id == self.member_id:
            return False
        held = self.members.get(message.member_id)
        if held is not None and (message.stamp_ns, message.seq) <= (held.stamp_ns, held.seq):
            return False
        self.members[message.member_id] = message
        return True

    def left(self, member_id: str) -> None:
        """A member's liveliness token was withdrawn: its tracks leave the picture at the next stamp."""
        self.members.pop(member_id, None)

    def present(self, stamp_ns: int) -> dict[str, MemberTracks]:
        """The other members present at ``stamp_ns``: heard within :data:`SILENT_S`; the silent ones are dropped."""
        silent = [m for m, msg in self.members.items() if stamp_ns - msg.stamp_ns > SILENT_S * NS_PER_S]
        for member_id in silent:
            del self.members[member_id]
        return dict(self.members)

    def update(self, stamp_ns: int, own: OwnTracks) -> Picture:
        """The picture at ``stamp_ns`` with the member's own confirmed tracks ``own`` (module docstring)."""
        held: dict[str, list[_Held]] = {}
        for member_id, message in sorted(self.present(stamp_ns).items()):
            for track in message.tracks:
                mean, cov = predict_to(self.motion, np.array(track.state), np.array(track.covariance).reshape(4, 4),
                                       track.stamp_ns, stamp_ns)
                held.setdefault(track.global_id, []).append(
                    _Held(member_id, mean, cov, track.detected_ns, GlobalName(track.global_id, track.born_ns)))
        known = [KnownTarget(rows[0].name, *self._fused_position(rows), held=True,
                             holders=tuple(HolderTrack(r.member, r.mean[:2], r.cov[:2, :2]) for r in rows))
                 for rows in held.values()]
        for gid, gone in sorted(self._lost.items()):
            if gid not in held:
                mean, cov = self._lost_at(gone, stamp_ns)
                known.append(KnownTarget(gone.name, mean[:2], cov[:2, :2], held=False))
        names = self.names.assign(stamp_ns, own.ids.tolist(), own.means[:, :2], own.covs[:, :2, :2], known)
        for row, track_id in enumerate(own.ids.tolist()):
            name = names[int(track_id)]
            held.setdefault(name.global_id, []).append(
                _Held(self.member_id, own.means[row], own.covs[row], int(own.detected_ns[row]), name))
        targets = tuple(self._target(gid, rows) for gid, rows in sorted(held.items()))
        self._mark_lost({t.name.global_id: t for t in targets}, stamp_ns)
        lost = tuple(GlobalTarget(gone.name, *self._lost_at(gone, stamp_ns), holders=(), detected_ns=gone.detected_ns)
                     for _, gone in sorted(self._lost.items()))
        return Picture(stamp_ns, targets, lost, names)

    def _fuse(self, rows: Sequence[_Held]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.fusion(np.array([r.mean for r in rows]), np.array([r.cov for r in rows]))

    def _fused_position(self, rows: Sequence[_Held]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        mean, cov = self._fuse(rows)
        return mean[:2], cov[:2, :2]

    def _target(self, gid: str, rows: Sequence[_Held]) -> GlobalTarget:
        mean, cov = self._fuse(rows)
        newest = max(r.detected_ns for r in rows)
        name = min((r.name for r in rows), key=lambda n: (n.born_ns, n.global_id))
        recent = newest - RECENT_DETECTION_S * NS_PER_S
        return GlobalTarget(GlobalName(gid, name.born_ns), mean, cov, tuple(sorted({r.member for r in rows})), newest,
                            tuple(sorted({r.member for r in rows if r.detected_ns >= recent})))

    def _lost_at(self, lost: _Lost, stamp_ns: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return predict_to(self.motion, lost.mean, lost.cov, lost.stamp_ns, stamp_ns)

    def _mark_lost(self, targets: dict[str, GlobalTarget], stamp_ns: int) -> None:
        """Held before and not now: lost, unless it gates with a target held now (renamed); lost and held again:
        found; lost too long: forgotten."""
        for gid, before in self._held.items():
            if gid not in targets and not self._merged(before, targets.values(), stamp_ns):
                self._lost[gid] = _Lost(before.name, before.mean, before.cov, self._held_stamp_ns, before.detected_ns)
        for gid in list(self._lost):
            if gid in targets or stamp_ns - self._lost[gid].detected_ns > self.forget_s * NS_PER_S:
                del self._lost[gid]
        self._held, self._held_stamp_ns = targets, stamp_ns

    def _merged(self, gone: GlobalTarget, held: Iterable[GlobalTarget], stamp_ns: int) -> bool:
        mean, cov = predict_to(self.motion, gone.mean, gone.cov, self._held_stamp_ns, stamp_ns)
        return any(position_distance2(mean[:2], cov[:2, :2], target.mean[:2], target.cov[:2, :2]) < self._merge_gate
                   for target in held)
