"""Which targets a member's team plans for, so that the teams of a federation share the work without talking.

Every member decides from the same published picture (each member's area, team centre and spare
vehicles, and the targets by global id), so they agree without a negotiation:

* **area**: a target whose position lies in a member's area is that member's;
* **handing over**: a member that holds a track on a target which has driven into another live
  member's area keeps planning for it until that member has it in sight itself
  (:attr:`GlobalTarget.detected_by <gcs.core.federation.picture.GlobalTarget.detected_by>`); then the
  hand-over is complete and only the area's member plans for it;
* **search**: a target that no live member's area contains, or that is lost (no member holds a track
  on it), is searched for by the member whose area contains it, else by the nearest team (its
  centre to the target) that has a vehicle to spare, else by the nearest team.

A member's spare vehicles are those its own area's targets leave: ``max(0, vehicles - area targets)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from gcs.core.federation.picture import GlobalTarget, Picture

__all__ = ["Area", "Team", "Claim", "claims", "area_owner", "spare_vehicles"]

Area = tuple[float, float, float, float]
"""``(x_min, y_min, x_max, y_max)``, ENU metres."""


@dataclass(frozen=True)
class Team:
    """What a member publishes of its team: its area, the centre of its vehicles, how many it has and can spare."""

    area: Area
    centre_xy: tuple[float, float]
    vehicles: int
    spare: int


@dataclass(frozen=True)
class Claim:
    """A target a member plans for, and why."""

    target: GlobalTarget
    reason: Literal["area", "handing_over", "search"]


def _inside(area: Area, xy: NDArray[np.float64]) -> bool:
    x, y = float(xy[0]), float(xy[1])
    return area[0] <= x < area[2] and area[1] <= y < area[3]


def area_owner(teams: Mapping[str, Team], xy: NDArray[np.float64]) -> str | None:
    """The member whose area contains ``xy`` (the first by id where areas overlap); None outside every area."""
    return next((member for member in sorted(teams) if _inside(teams[member].area, xy)), None)


def spare_vehicles(area: Area, vehicles: int, targets: Sequence[GlobalTarget]) -> int:
    """The vehicles a team can spare: ``max(0, vehicles - targets held in its area)``."""
    return max(0, vehicles - sum(1 for t in targets if _inside(area, t.mean[:2])))


def _nearest(teams: Mapping[str, Team], xy: NDArray[np.float64]) -> str:
    with_spare = [m for m in sorted(teams) if teams[m].spare > 0] or sorted(teams)
    return min(with_spare, key=lambda m: (float(np.hypot(*(np.array(teams[m].centre_xy) - xy[:2]))), m))


def claims(member_id: str, picture: Picture, teams: Mapping[str, Team]) -> list[Claim]:
    """The targets of ``picture`` that ``member_id`` plans for (module docstring), given every live member's team
    (``member_id``'s included)."""
    if member_id not in teams:
        raise ValueError(f"member {member_id!r} is not among the teams {sorted(teams)}")
    out: list[Claim] = []
    for target in picture.targets:
        xy = target.mean[:2]
        owner = area_owner(teams, xy)
        if owner == member_id:
            out.append(Claim(target, "area"))
        elif owner is not None:
            if member_id in target.holders and owner not in target.detected_by:
                out.append(Claim(target, "handing_over"))
        elif _nearest(teams, xy) == member_id:
            out.append(Claim(target, "search"))
    for target in picture.lost:
        xy = target.mean[:2]
        owner = area_owner(teams, xy)
        if (owner or _nearest(teams, xy)) == member_id:
            out.append(Claim(target, "search"))
    return out
