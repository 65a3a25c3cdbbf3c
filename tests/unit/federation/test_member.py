"""The engine's federation member: what it takes from the wire, what it rejects and counts, what it publishes."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from gcs.core.federation import OwnTracks
from gcs.core.models.motion import constant_velocity
from gcs.engine.federation import FederationMember, FederationOptions
from protocols.codec import decode, encode
from protocols.federation import MemberTracks
from protocols.keys import member_alive_key, member_tracks_key

S = 1_000_000_000


def _member(member_id: str = "west") -> FederationMember:
    options = FederationOptions(member_id, (0.0, 0.0, 1000.0, 1000.0), prefix="city")
    return FederationMember(options, constant_velocity(1.0), 20.0, Counter())


def _tracks(member_id: str, stamp_s: int) -> MemberTracks:
    return MemberTracks(member_id=member_id, seq=stamp_s, stamp_ns=stamp_s * S,
                        area_enu_m=(1000.0, 0.0, 2000.0, 1000.0), team_xy_m=(1500.0, 500.0), vehicles=3,
                        spare_vehicles=3)


def test_bad_federation_input_is_rejected_counted_and_fuses_nothing() -> None:
    member = _member()
    key = member_tracks_key("east", "city")
    payload, encoding = encode(_tracks("east", 1))
    member.arrived("sample", key, b"{not json", encoding)
    member.arrived("sample", member_tracks_key("north", "city"), payload, encoding)  # east's message on north's key
    member.arrived("sample", "city/federation/east/plans", payload, encoding)
    assert member.counters["rejected.federation"] == 3
    assert member.picture.members == {}
    member.arrived("sample", key, payload, encoding)
    assert member.counters["federation.heard"] == 1 and list(member.picture.members) == ["east"]


def test_a_withdrawn_token_takes_the_member_out_and_its_own_token_is_not_counted() -> None:
    member = _member()
    payload, encoding = encode(_tracks("east", 1))
    member.arrived("sample", member_tracks_key("east", "city"), payload, encoding)
    member.arrived("alive", member_alive_key("west", "city"), b"", "")
    member.arrived("gone", member_alive_key("east", "city"), b"", "")
    assert member.counters["federation.left"] == 1 and member.counters["federation.joined"] == 0
    assert member.picture.members == {}


def test_published_tracks_decode_and_carry_the_own_tracks_under_their_global_ids() -> None:
    member = _member()
    own = OwnTracks(np.array([4]), np.array([[100.0, 200.0, 5.0, 0.0]]), np.array([np.diag([25.0, 25.0, 4.0, 4.0])]),
                    np.array([7 * S]))
    class Config:  # the planner's settings the member reads: the step and the horizon
        step_s, horizon_steps, predict_ahead = 1.0, 5, True

    team = [(400.0, 500.0, 200.0), (500.0, 400.0, 210.0), (600.0, 600.0, 220.0)]
    published, plan = member.after_scan(7 * S, own, team, Config())  # type: ignore[arg-type]
    message = decode(*encode(published.message), MemberTracks)
    assert message == published.message
    (track,) = message.tracks
    assert (track.global_id, track.local_id, track.detected_ns) == ("west-t4-7", "t4", 7 * S)
    np.testing.assert_allclose(np.array(track.covariance).reshape(4, 4), own.covs[0])
    assert message.spare_vehicles == 2 and message.vehicles == 3  # one target in its own area
    assert message.team_xy_m == (500.0, 500.0)
    assert plan is not None and plan.ids == ("west-t4-7",) and plan.means.shape == (1, 5, 4)


def test_options_name_a_bad_area_or_rule() -> None:
    with pytest.raises(ValueError, match="min < max"):
        FederationOptions("west", (10.0, 0.0, 0.0, 5.0))
    with pytest.raises(ValueError, match="fusion rule"):
        FederationOptions("west", (0.0, 0.0, 1.0, 1.0), fusion="average")
