"""The engine as a member of a federation of daemons: what it publishes, what it takes in, what it plans for.

With :class:`FederationOptions` (``gcs run --federation PREFIX --member ID --area X0,Y0,X1,Y1``), an
engine tracking many targets (``[multitarget]``) is one member of a federation
(:mod:`protocols.federation`):

* **in**: the other members' :class:`~protocols.federation.MemberTracks` and liveliness, fed as
  :class:`~gcs.engine.events.Arrived` inputs on ``<federation>/federation/<member>/tracks|alive``;
  a message that does not decode is rejected and counted (``rejected.federation``), never fused;
* **picture**: after each scan, the member's confirmed tracks are named by global id and fused
  with the others' into the picture of the stamp (:class:`gcs.core.federation.FederatedPicture`);
* **out**: a :class:`PublishMemberTracks` action with the own tracks (own detections only), the
  area, the team's centre and spare vehicles, and the lost targets it searches for;
* **plan**: the vehicles are planned for the targets the coordination rules give the member
  (:func:`gcs.core.federation.claims`), each on its fused (or, lost, predicted) estimate, weighted by
  the time since anyone last detected it.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gcs.core.federation import FUSION_RULES, Claim, FederatedPicture, OwnTracks, Picture, Team, claims
from gcs.core.federation.coordination import Area, spare_vehicles
from gcs.core.models.motion import LinearMotionModel
from gcs.core.multitarget.planning import TargetsToPlan, targets_to_plan
from gcs.core.tracker import TrackerConfig
from protocols.codec import decode
from protocols.errors import ProtocolError
from protocols.federation import FederatedTrack, MemberTracks
from protocols.keys import parse_key

__all__ = ["FederationOptions", "FederationMember", "PublishMemberTracks"]

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class FederationOptions:
    """A member's place in a federation: its id, the federation's key prefix, its area
    (``x_min, y_min, x_max, y_max``, ENU metres), the fusion rule (:data:`gcs.core.federation.FUSION_RULES`) and how
    long a lost target is searched for."""

    member_id: str
    area: Area
    prefix: str = "federation"
    fusion: str = "ci"
    forget_s: float = 90.0

    def __post_init__(self) -> None:
        if self.fusion not in FUSION_RULES:
            raise ValueError(f"unknown fusion rule {self.fusion!r}; expected one of {', '.join(FUSION_RULES)}")
        x_min, y_min, x_max, y_max = self.area
        if not (x_min < x_max and y_min < y_max):
            raise ValueError(f"area {self.area!r} must be x_min,y_min,x_max,y_max with min < max")


@dataclass(frozen=True)
class PublishMemberTracks:
    """The member's tracks and team, to publish on ``<federation>/federation/<member>/tracks``."""

    message: MemberTracks
    claims: tuple[Claim, ...]
    picture: Picture


class FederationMember:
    """One engine's membership of a federation (module docstring)."""

    def __init__(self, options: FederationOptions, motion: LinearMotionModel, starvation_s: float,
                 counters: Counter[str]) -> None:
        """``starvation_s``: the ``[multitarget]`` time in which an unseen target's planning weight doubles."""
        self.options, self.starvation_s, self.counters = options, starvation_s, counters
        self.picture = FederatedPicture(options.member_id, motion, FUSION_RULES[options.fusion], options.forget_s)
        self.seq = 0
        self.latest: PublishMemberTracks | None = None
        """The newest step's message, claims and picture."""

    def owns(self, key: str) -> bool:
        """Whether ``key`` is in the federation's key space (its inputs come here, not to the team's ingest)."""
        return key.startswith(self.options.prefix + "/federation/")

    def arrived(self, kind: str, key: str, payload: bytes, encoding: str) -> None:
        """A federation sample or liveliness change (module docstring)."""
        try:
            parsed = parse_key(key, self.options.prefix)
            if kind in ("alive", "gone"):
                if parsed.kind == "member_alive" and parsed.ident != self.options.member_id:
                    if kind == "gone":
                        self.picture.left(str(parsed.ident))
                    log.info("federation member %s %s", parsed.ident, "joined" if kind == "alive" else "left")
                    self.counters[f"federation.{'joined' if kind == 'alive' else 'left'}"] += 1
                return
            message = decode(payload, encoding, MemberTracks)
            if parsed.kind != "member" or parsed.ident != message.member_id:
                raise ProtocolError(f"member {message.member_id!r} published on {key!r}", reason="key")
        except ProtocolError as error:
            self.counters["rejected.federation"] += 1
            log.warning("federation input rejected: %s", error)
            return
        if self.picture.heard(message):
            self.counters["federation.heard"] += 1

    def after_scan(self, stamp_ns: int, own: OwnTracks, team: Sequence[Sequence[float]], config: TrackerConfig
                   ) -> tuple[PublishMemberTracks, TargetsToPlan | None]:
        """The picture at the scan's stamp, the message to publish, and the targets to plan for (None: none);
        ``team``: where the member's vehicles that can be planned for are (x, y, ...)."""
        picture = self.picture.update(stamp_ns, own)
        area = self.options.area
        vehicles = len(team)
        team_xy = ((float(np.mean([p[0] for p in team])), float(np.mean([p[1] for p in team]))) if team
                   else (0.5 * (area[0] + area[2]), 0.5 * (area[1] + area[3])))  # none yet: the area's centre
        spare = spare_vehicles(area, vehicles, picture.targets)
        teams = {member: Team(m.area_enu_m, m.team_xy_m, m.vehicles, m.spare_vehicles)
                 for member, m in self.picture.present(stamp_ns).items()}
        teams[self.options.member_id] = Team(area, team_xy, vehicles, spare)
        mine = claims(self.options.member_id, picture, teams)
        self.seq += 1
        tracks = []
        for row, track_id in enumerate(own.ids.tolist()):
            name = picture.own_names[int(track_id)]
            tracks.append(FederatedTrack(global_id=name.global_id, born_ns=name.born_ns, local_id=f"t{track_id}",
                                         stamp_ns=stamp_ns, state=tuple(map(float, own.means[row])),
                                         covariance=tuple(map(float, own.covs[row].ravel())),
                                         detected_ns=int(own.detected_ns[row])))
        message = MemberTracks(member_id=self.options.member_id, seq=self.seq, stamp_ns=stamp_ns, area_enu_m=area,
                               team_xy_m=team_xy, vehicles=vehicles, spare_vehicles=spare, tracks=tuple(tracks),
                               searching=tuple(c.target.name.global_id for c in mine if c.reason == "search"))
        self.latest = PublishMemberTracks(message, tuple(mine), picture)
        if not mine:
            return self.latest, None
        ids = tuple(c.target.name.global_id for c in mine)
        means = np.array([c.target.mean for c in mine])
        covs = np.array([c.target.cov for c in mine])
        unseen = np.array([max(0.0, (stamp_ns - c.target.detected_ns) / NS_PER_S) for c in mine])
        plan = targets_to_plan(ids, means, covs, unseen, self.picture.motion, config.step_s, config.horizon_steps,
                               self.starvation_s, config.predict_ahead)
        return self.latest, plan
