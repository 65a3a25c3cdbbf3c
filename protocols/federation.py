"""What the daemons of a federation tell each other: each member's tracks and where its team works.

Several ground stations, each flying its own team under its own prefix, act as one through a
shared federation prefix (``gcs federation`` key space, :mod:`protocols.keys`): every member
publishes a :class:`MemberTracks` each decision step on ``<federation>/federation/<member>/tracks``
and holds a liveliness token on ``<federation>/federation/<member>/alive`` while it runs.

A member publishes only what its own vehicles measured (its **local** tracks), never what it fused
from the others: a track's information then never travels back to where it came from, and the
receivers fuse the members' tracks with a rule that does not assume them independent (covariance
intersection, :mod:`gcs.core.federation.fusion`). Each local track carries the **global id** the
federation knows the target by, and when that id was first given, so that two members that named
the same car at once agree on the older name (:mod:`gcs.core.federation.global_ids`).
"""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta

from protocols.base import Message
from protocols.errors import ProtocolError
from protocols.fields import Count, CovarianceEntry, Ident, PositionM, Seq, StampNs, StateValue, check_covariance

__all__ = ["FederatedTrack", "MemberTracks", "MAX_MEMBER_TRACKS", "FEDERATED_STATE_DIM"]

MAX_MEMBER_TRACKS = 256
"""Tracks one :class:`MemberTracks` lists at most."""
FEDERATED_STATE_DIM = 4
"""A federated track's state: [x, y, vx, vy], ENU metres and metres per second (``cv2d``)."""


class FederatedTrack(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One of a member's confirmed tracks, made from its own vehicles' detections only.

    Attributes
    ----------
    global_id : str
        The id the federation knows the target by.
    born_ns : int
        When ``global_id`` was first given (the older of two names for one target wins).
    local_id : str
        The member's own id of the track (``t<n>``).
    stamp_ns : int
        Time the estimate is valid for.
    state : tuple of 4 float
        [x, y, vx, vy], ENU.
    covariance : tuple of 16 float
        Row-major 4 x 4 covariance, symmetric, diagonal >= 0.
    detected_ns : int
        Stamp of the member's newest detection of the target.
    """

    global_id: Ident
    born_ns: StampNs
    local_id: Ident
    stamp_ns: StampNs
    state: Annotated[tuple[StateValue, ...], Meta(min_length=FEDERATED_STATE_DIM, max_length=FEDERATED_STATE_DIM)]
    covariance: Annotated[tuple[CovarianceEntry, ...],
                          Meta(min_length=FEDERATED_STATE_DIM ** 2, max_length=FEDERATED_STATE_DIM ** 2)]
    detected_ns: StampNs

    def __post_init__(self) -> None:
        check_covariance(self.covariance, FEDERATED_STATE_DIM, "covariance")


class MemberTracks(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """What one member of a federation publishes each decision step.

    Attributes
    ----------
    member_id : str
        The member (one daemon and its team).
    seq, stamp_ns
        The member's sequence number, and the decision step the tracks are valid for.
    area_enu_m : tuple of 4 float
        The member's area, ``(x_min, y_min, x_max, y_max)`` ENU metres: the targets inside are its to keep in
        sight.
    team_xy_m : tuple of 2 float
        The centre of its vehicles (ENU), for choosing the nearest team to search for a lost target.
    vehicles, spare_vehicles : int
        Its vehicles alive, and how many of them its own area's targets leave free.
    tracks : tuple of FederatedTrack
        Its confirmed tracks.
    searching : tuple of str
        Global ids of the targets it searches for: lost ones (no member holds a track on them), and held
        ones in no live member's area (a member that died, say).
    """

    member_id: Ident
    seq: Seq
    stamp_ns: StampNs
    area_enu_m: tuple[PositionM, PositionM, PositionM, PositionM]
    team_xy_m: tuple[PositionM, PositionM]
    vehicles: Count
    spare_vehicles: Count
    tracks: Annotated[tuple[FederatedTrack, ...], Meta(max_length=MAX_MEMBER_TRACKS)] = ()
    searching: Annotated[tuple[Ident, ...], Meta(max_length=MAX_MEMBER_TRACKS)] = ()

    def __post_init__(self) -> None:
        x_min, y_min, x_max, y_max = self.area_enu_m
        if not (x_min < x_max and y_min < y_max):
            raise ProtocolError(f"area {self.area_enu_m!r} must be (x_min, y_min, x_max, y_max) with min < max",
                                field="$.area_enu_m")
        if self.spare_vehicles > self.vehicles:
            raise ProtocolError(f"spare_vehicles {self.spare_vehicles} exceeds vehicles {self.vehicles}",
                                field="$.spare_vehicles")
