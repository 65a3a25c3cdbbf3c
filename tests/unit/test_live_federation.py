"""The live map of a federation member: every member's area and every global target, with its ellipse, holders,
lost flag and this member's claim, as the page gets them (no network)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gcs.adapters.live_map.outputs import LiveMap
from gcs.adapters.live_map.picture import Picture
from gcs.adapters.live_map.picture_geometry import SIGMAS, encode_json
from gcs.config.world import build_world
from gcs.core.federation import FederatedPicture, OwnTracks, Team, claims
from gcs.core.models.motion import constant_velocity
from gcs.engine.federation import PublishMemberTracks
from gcs.scenarios import load_scenario
from protocols.federation import FederatedTrack, MemberTracks

S = 1_000_000_000
SCENARIO = load_scenario("wang2012_urban")
WEST, EAST, NORTH = (0.0, 0.0, 1000.0, 1000.0), (1000.0, 0.0, 2000.0, 1000.0), (0.0, 1000.0, 2000.0, 2000.0)
CENTRES = {"west": (500.0, 500.0), "east": (1500.0, 500.0), "north": (1000.0, 1500.0)}
COV = np.diag([25.0, 16.0, 4.0, 4.0])
COV[0, 1] = COV[1, 0] = 6.0  # a tilted ellipse


def _member(member: str, stamp_s: float, area, tracks: list[tuple[str, tuple[float, float]]]) -> MemberTracks:
    return MemberTracks(member_id=member, seq=int(stamp_s), stamp_ns=int(stamp_s * S), area_enu_m=area,
                        team_xy_m=CENTRES[member], vehicles=3, spare_vehicles=2,
                        tracks=tuple(FederatedTrack(global_id=gid, born_ns=0, local_id="t1", stamp_ns=int(stamp_s * S),
                                                    state=(x, y, 10.0, 0.0), covariance=tuple(COV.ravel()),
                                                    detected_ns=int(stamp_s * S)) for gid, (x, y) in tracks))


def _own(stamp_s: float, tracks: dict[int, tuple[float, float]]) -> OwnTracks:
    ids = sorted(tracks)
    return OwnTracks(np.array(ids, dtype=np.int64), np.array([[*tracks[i], 10.0, 0.0] for i in ids]).reshape(-1, 4),
                     np.array([COV] * len(ids)).reshape(-1, 4, 4), np.full(len(ids), int(stamp_s * S), dtype=np.int64))


def _step(federation: FederatedPicture, stamp_s: float, own: dict[int, tuple[float, float]]) -> PublishMemberTracks:
    """What the engine of member ``west`` publishes at ``stamp_s`` (its own message, picture and claims)."""
    picture = federation.update(int(stamp_s * S), _own(stamp_s, own))
    teams = {m: Team(msg.area_enu_m, msg.team_xy_m, msg.vehicles, msg.spare_vehicles)
             for m, msg in federation.present(int(stamp_s * S)).items()}
    teams["west"] = Team(WEST, CENTRES["west"], 3, 2)
    message = MemberTracks(member_id="west", seq=int(stamp_s), stamp_ns=int(stamp_s * S), area_enu_m=WEST,
                           team_xy_m=CENTRES["west"], vehicles=3, spare_vehicles=2)
    return PublishMemberTracks(message, tuple(claims("west", picture, teams)), picture)


def _snapshot(picture: Picture) -> dict:
    return json.loads(encode_json(picture.snapshot()[0]))


def first_step() -> tuple[FederatedPicture, PublishMemberTracks]:
    """Step 1 (10 s): east holds east-t1 in its area, north holds north-t1 in its; west holds west-t4-10 in its own
    area and west-t3-10, a car that has crossed into east's area and that east does not see (a hand-over)."""
    federation = FederatedPicture("west", constant_velocity(1.0))
    federation.heard(_member("east", 10.0, EAST, [("east-t1", (1500.0, 500.0))]))
    federation.heard(_member("north", 10.0, NORTH, [("north-t1", (500.0, 1500.0))]))
    return federation, _step(federation, 10.0, {3: (1050.0, 500.0), 4: (200.0, 200.0)})


def second_step(federation: FederatedPicture) -> PublishMemberTracks:
    """Step 2 (11 s): east has left and west deleted its track on west-t3-10: both cars are lost."""
    federation.left("east")
    return _step(federation, 11.0, {4: (210.0, 200.0)})


@pytest.fixture
def flight() -> tuple[FederatedPicture, Picture]:
    federation, published = first_step()
    picture = Picture(SCENARIO, build_world(SCENARIO))
    picture.observe_federation(published, federation.members)
    return federation, picture


def _by_id(document: dict) -> dict[str, dict]:
    return {t["global_id"]: t for t in document["federation"]["targets"]}


def test_every_members_area_and_every_target_with_its_holders_and_claim(flight) -> None:
    _, picture = flight
    document = _snapshot(picture)["federation"]
    assert document["member_id"] == "west" and document["stamp_ns"] == 10 * S
    areas = {m["id"]: (m["area"], m["own"], m["vehicles"], m["spare"]) for m in document["members"]}
    assert areas == {"west": (list(WEST), True, 3, 2), "east": (list(EAST), False, 3, 2),
                     "north": (list(NORTH), False, 3, 2)}
    assert document["members"][0]["id"] == "west"  # this member first
    targets = _by_id(_snapshot(picture))
    assert {gid: (t["holders"], t["lost"], t["claim"]) for gid, t in targets.items()} == {
        "east-t1": (["east"], False, None), "north-t1": (["north"], False, None),
        "west-t3-10": (["west"], False, "handing_over"), "west-t4-10": (["west"], False, "area")}
    assert (targets["west-t3-10"]["x"], targets["west-t3-10"]["y"]) == (1050.0, 500.0)  # its own track, held by it alone
    assert targets["west-t3-10"]["vx"] == 10.0


def test_a_dead_members_targets_and_a_deleted_own_track_are_lost_and_searched_for(flight) -> None:
    """Step 2: the lost cars are in no live member's area, and west (the nearest team) searches for them; they are
    drawn where the motion model puts them."""
    federation, picture = flight
    published = second_step(federation)
    picture.observe_federation(published, federation.members)
    document = _snapshot(picture)
    assert [m["id"] for m in document["federation"]["members"]] == ["west", "north"]
    targets = _by_id(document)
    assert {gid: (t["holders"], t["lost"], t["claim"]) for gid, t in targets.items()} == {
        "east-t1": ([], True, "search"), "west-t3-10": ([], True, "search"),
        "north-t1": (["north"], False, None), "west-t4-10": (["west"], False, "area")}
    assert targets["east-t1"]["x"] == pytest.approx(1500.0 + 10.0, abs=0.05)  # 1 s on at 10 m/s
    assert targets["west-t3-10"]["x"] == pytest.approx(1050.0 + 10.0, abs=0.05)
    core = {t.name.global_id: t for t in published.picture.targets + published.picture.lost}
    for gid, drawn in targets.items():  # the 2-sigma ellipse of each position covariance, by its eigenvalues
        values, vectors = np.linalg.eigh(core[gid].cov[:2, :2])
        assert drawn["ellipse"]["rx"] == pytest.approx(SIGMAS * math.sqrt(values[1]), abs=0.05)
        assert drawn["ellipse"]["ry"] == pytest.approx(SIGMAS * math.sqrt(values[0]), abs=0.05)
        major = vectors[:, 1]
        assert abs(math.sin(drawn["ellipse"]["angle_rad"] - math.atan2(major[1], major[0]))) < 1e-3
    assert targets["east-t1"]["ellipse"]["rx"] > SIGMAS * math.sqrt(np.linalg.eigvalsh(COV[:2, :2])[1])  # grown


def test_an_older_picture_does_not_replace_a_newer_one(flight) -> None:
    federation, picture = flight
    newer = _step(federation, 11.0, {4: (210.0, 200.0)})
    picture.observe_federation(newer, federation.members)
    older = _step(FederatedPicture("west", constant_velocity(1.0)), 9.0, {})
    picture.observe_federation(older, {})
    assert _snapshot(picture)["federation"]["stamp_ns"] == 11 * S


def test_a_daemon_outside_a_federation_has_no_federation_part() -> None:
    tracks, summary = Picture(SCENARIO, build_world(SCENARIO)).snapshot()
    assert "federation" not in tracks and "federation" not in summary


def test_the_live_map_passes_the_federation_on_and_counts_a_failure(flight) -> None:
    federation, _ = flight
    live = LiveMap(Picture(SCENARIO, build_world(SCENARIO)), None)
    live.observe_federation(_step(federation, 11.0, {4: (210.0, 200.0)}), federation.members)
    assert _snapshot(live.picture)["federation"]["stamp_ns"] == 11 * S
    live.observe_federation(None, {})  # type: ignore[arg-type]  # a bug upstream: counted, the map keeps the last
    assert live.picture.counters["errors.live_map"] == 1
    assert _snapshot(live.picture)["federation"]["stamp_ns"] == 11 * S
