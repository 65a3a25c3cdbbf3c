"""The federation's part of the live map: every member's area and every target of the federation by its global id.

A daemon that is a member of a federation (``docs/federation.md``) publishes, after each scan, a
:class:`~gcs.engine.federation.PublishMemberTracks`: its own :class:`~protocols.federation.MemberTracks`, the
member's :class:`~gcs.core.federation.Picture` (every target by global id, fused, and the lost ones), and the
:class:`~gcs.core.federation.Claim` s it plans for. With the other members' newest messages (their areas and teams)
:func:`federation_document` makes of it the ``federation`` part of the ``/api/tracks`` document:

* ``member_id``: this daemon's member id, and ``stamp_ns``, the picture's stamp;
* ``members``: one entry per member, this one first, then the others by id: ``id``, ``area``
  (``[x_min, y_min, x_max, y_max]``, ENU m), ``team_xy`` (the centre of its vehicles), ``vehicles``, ``spare``
  (vehicles its own area's targets leave free), ``stamp_ns`` (of its message) and ``own``;
* ``targets``: the held targets by global id, then the lost ones: ``global_id``, ``x``, ``y``, ``vx``, ``vy`` (the
  fused or, lost, predicted estimate), ``ellipse`` (the 2-sigma ellipse of the position covariance,
  :func:`~gcs.adapters.live_map.picture_geometry.ellipse`), ``holders`` (members holding a track on it; empty when
  lost), ``detected_by`` (holders with it in sight), ``lost``, and ``claim``: why this member plans for it
  (``area``, ``handing_over`` or ``search``), None when it does not.

The document is made once per decision step, when the action comes, and kept as it is for the snapshots.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from gcs.adapters.live_map.picture_geometry import ellipse
from gcs.adapters.live_map.picture_geometry import rounded as _r
from gcs.core.federation import GlobalTarget
from gcs.engine.federation import PublishMemberTracks
from protocols.federation import MemberTracks

__all__ = ["federation_document"]


def _member(message: MemberTracks, own: bool) -> dict:
    return {"id": message.member_id, "own": own, "stamp_ns": message.stamp_ns,
            "area": [_r(v) for v in message.area_enu_m], "team_xy": [_r(v) for v in message.team_xy_m],
            "vehicles": message.vehicles, "spare": message.spare_vehicles}


def _target(target: GlobalTarget, lost: bool, claim: str | None) -> dict:
    mean = np.asarray(target.mean, dtype=np.float64)
    cov = np.asarray(target.cov, dtype=np.float64)
    return {"global_id": target.name.global_id, "x": _r(mean[0]), "y": _r(mean[1]),
            "vx": round(float(mean[2]), 2), "vy": round(float(mean[3]), 2), "ellipse": ellipse(cov[:2, :2]),
            "holders": list(target.holders), "detected_by": list(target.detected_by), "lost": lost, "claim": claim}


def federation_document(published: PublishMemberTracks, members: Mapping[str, MemberTracks]) -> dict:
    """The ``federation`` part of the tracks document (module docstring) from this member's action and the other
    members' newest messages (``members``: member id -> message; this member's own id there is ignored)."""
    own = published.message
    claimed = {c.target.name.global_id: c.reason for c in published.claims}
    picture = published.picture
    return {
        "member_id": own.member_id,
        "stamp_ns": picture.stamp_ns,
        "members": [_member(own, True)] + [_member(members[m], False) for m in sorted(members) if m != own.member_id],
        "targets": [_target(t, False, claimed.get(t.name.global_id)) for t in picture.targets]
                   + [_target(t, True, claimed.get(t.name.global_id)) for t in picture.lost],
    }
