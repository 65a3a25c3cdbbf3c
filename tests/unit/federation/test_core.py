"""The federation's numerics: covariance intersection, the naming rules, the picture and who plans for what."""

from __future__ import annotations

import numpy as np
import pytest

from gcs.core.federation import FederatedPicture, GlobalNames, OwnTracks, Team, claims, covariance_intersection
from gcs.core.federation.fusion import independent_fusion, predict_to
from gcs.core.federation.global_ids import GlobalName, HolderTrack, KnownTarget
from gcs.core.models.motion import constant_velocity
from protocols.federation import FederatedTrack, MemberTracks

S = 1_000_000_000


def test_intersection_is_consistent_where_the_information_sum_is_not() -> None:
    """Two estimates made from one shared measurement plus independent ones (correlation 0.8): the information sum
    claims too small a covariance, the intersection does not (its normalised error follows a chi-square at most)."""
    rng = np.random.default_rng(7)
    n, runs = 2, 4000
    cov = np.diag([4.0, 9.0])
    shared_part, own_part = 0.8, 0.2
    nees_ci, nees_sum = [], []
    for _ in range(runs):
        shared = rng.multivariate_normal(np.zeros(n), shared_part * cov)
        a = shared + rng.multivariate_normal(np.zeros(n), own_part * cov)
        b = shared + rng.multivariate_normal(np.zeros(n), own_part * cov)
        for rule, out in ((covariance_intersection, nees_ci), (independent_fusion, nees_sum)):
            mean, fused = rule(np.array([a, b]), np.array([cov, cov]))
            out.append(float(mean @ np.linalg.solve(fused, mean)))
    assert np.mean(nees_ci) <= n * 1.05  # consistent: the mean NEES does not exceed the dimension
    assert np.mean(nees_sum) > n * 1.4  # the sum counts the shared information twice (expected 1.8 n)


def test_intersection_keeps_the_better_estimate_whole_when_the_other_adds_nothing() -> None:
    mean, cov = covariance_intersection(np.array([[0.0, 0.0], [5.0, 5.0]]),
                                        np.array([np.eye(2), 100.0 * np.eye(2)]))
    np.testing.assert_allclose(mean, [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(cov, np.eye(2), atol=1e-9)


def test_intersection_of_crossed_ellipses_is_smaller_than_either() -> None:
    mean, cov = covariance_intersection(np.zeros((2, 2)), np.array([np.diag([1.0, 100.0]), np.diag([100.0, 1.0])]))
    assert np.linalg.det(cov) < 1.0 * 100.0 / 10
    assert np.all(np.linalg.eigvalsh(cov) > 0.0)


def _known(gid: str, born: int, xy: tuple[float, float], held: bool = True) -> KnownTarget:
    return KnownTarget(GlobalName(gid, born), np.array(xy), 25.0 * np.eye(2), held)


def test_a_new_track_takes_the_name_of_the_target_it_gates_with() -> None:
    names = GlobalNames("south")
    out = names.assign(10 * S, [4, 5], np.array([[100.0, 0.0], [900.0, 0.0]]), np.array([25.0 * np.eye(2)] * 2),
                       [_known("north-t1", 2 * S, (104.0, 3.0))])
    assert out[4] == GlobalName("north-t1", 2 * S)
    assert out[5] == GlobalName("south-t5-10", 10 * S)  # nothing near: a new name, born now
    assert names.changes == 0


def test_two_names_for_one_car_end_in_the_older_on_both_sides() -> None:
    a, b = GlobalNames("a"), GlobalNames("b")
    cov = np.array([25.0 * np.eye(2)])
    name_a = a.assign(5 * S, [1], np.array([[0.0, 0.0]]), cov, [])[1]
    name_b = b.assign(5 * S, [7], np.array([[2.0, 1.0]]), cov, [])[7]
    assert name_a.global_id == "a-t1-5" and name_b.global_id == "b-t7-5"
    after_a = a.assign(6 * S, [1], np.array([[0.0, 0.0]]), cov, [_known(name_b.global_id, name_b.born_ns, (2, 1))])
    after_b = b.assign(6 * S, [7], np.array([[2.0, 1.0]]), cov, [_known(name_a.global_id, name_a.born_ns, (0, 0))])
    assert after_a[1] == after_b[7] == name_a  # born together: the smaller id wins
    assert (a.changes, b.changes) == (0, 1)


def _member(member: str, stamp_s: float, tracks: list[tuple[str, tuple[float, float]]],
            area=(0.0, 0.0, 1000.0, 1000.0)) -> MemberTracks:
    return MemberTracks(member_id=member, seq=int(stamp_s), stamp_ns=int(stamp_s * S), area_enu_m=area,
                        team_xy_m=(500.0, 500.0), vehicles=3, spare_vehicles=2,
                        tracks=tuple(FederatedTrack(global_id=gid, born_ns=0, local_id="t1", stamp_ns=int(stamp_s * S),
                                                    state=(x, y, 10.0, 0.0),
                                                    covariance=tuple(np.diag([25.0, 25.0, 4.0, 4.0]).ravel()),
                                                    detected_ns=int(stamp_s * S)) for gid, (x, y) in tracks))


def _own(xy: tuple[float, float] | None, stamp_s: float) -> OwnTracks:
    if xy is None:
        return OwnTracks.none()
    return OwnTracks(np.array([3]), np.array([[xy[0], xy[1], 10.0, 0.0]]), np.array([np.diag([25.0, 25.0, 4, 4])]),
                     np.array([int(stamp_s * S)]))


def test_picture_fuses_a_shared_target_once_and_keeps_a_dead_members_target_as_lost() -> None:
    picture = FederatedPicture("b", constant_velocity(1.0))
    picture.heard(_member("a", 10.0, [("a-t1", (990.0, 50.0))]))
    view = picture.update(int(11 * S), _own((1001.0, 50.0), 11.0))  # a's track predicted 1 s on: x 1000
    assert [t.name.global_id for t in view.targets] == ["a-t1"]
    assert view.targets[0].holders == ("a", "b")
    assert view.targets[0].mean[0] == pytest.approx(1000.5, abs=1.0)
    picture.left("a")
    view = picture.update(int(12 * S), _own(None, 12.0))  # b's own track was deleted too: lost
    assert view.targets == () and [t.name.global_id for t in view.lost] == ["a-t1"]
    view = picture.update(int(13 * S), _own((1030.0, 50.0), 13.0))  # found again: the name comes back
    assert [t.name.global_id for t in view.targets] == ["a-t1"] and view.lost == ()


def test_a_silent_member_is_gone_without_its_token_withdrawn() -> None:
    picture = FederatedPicture("b", constant_velocity(1.0))
    picture.heard(_member("a", 10.0, [("a-t1", (100.0, 50.0))]))
    assert list(picture.present(int(12 * S))) == ["a"]
    assert list(picture.present(int(14 * S))) == []


def test_claims_share_the_targets_by_area_then_hand_over_then_search() -> None:
    picture = FederatedPicture("west", constant_velocity(1.0))
    picture.heard(_member("east", 10.0, [("east-t1", (1500.0, 500.0))], area=(1000.0, 0.0, 2000.0, 1000.0)))
    view = picture.update(int(10 * S), _own((1050.0, 500.0), 10.0))  # west still holds a car that crossed east
    teams = {"west": Team((0.0, 0.0, 1000.0, 1000.0), (500.0, 500.0), 3, 3),
             "east": Team((1000.0, 0.0, 2000.0, 1000.0), (1500.0, 500.0), 3, 2)}
    mine = {c.target.name.global_id: c.reason for c in claims("west", view, teams)}
    assert mine == {"west-t3-10": "handing_over"}
    theirs = {c.target.name.global_id: c.reason for c in claims("east", view, teams)}
    assert theirs == {"east-t1": "area", "west-t3-10": "area"}
    del teams["east"]  # east is gone: its area's targets go to the nearest team with a vehicle to spare
    assert {c.target.name.global_id: c.reason for c in claims("west", view, teams)} == {
        "east-t1": "search", "west-t3-10": "search"}



def test_a_newer_estimate_taken_back_is_where_it_was_and_no_more_certain() -> None:
    motion = constant_velocity(1.0)
    mean, cov = np.array([100.0, 50.0, 10.0, -2.0]), np.diag([25.0, 25.0, 4.0, 4.0])
    back_mean, back_cov = predict_to(motion, mean, cov, 12 * S, 10 * S)
    np.testing.assert_allclose(back_mean, [80.0, 54.0, 10.0, -2.0])
    assert np.all(np.linalg.eigvalsh(back_cov - cov) > 0.0)  # the interval's process noise added, not removed
    forth_mean, _ = predict_to(motion, back_mean, back_cov, 10 * S, 12 * S)
    np.testing.assert_allclose(forth_mean, mean)


def _held_by(gid: str, born: int, holders: dict[str, tuple[float, float]]) -> KnownTarget:
    tracks = tuple(HolderTrack(member, np.array(xy), 25.0 * np.eye(2)) for member, xy in sorted(holders.items()))
    return KnownTarget(GlobalName(gid, born), tracks[0].position, tracks[0].position_cov, True, tracks)


def test_a_name_on_two_cars_stays_with_the_first_holder_and_those_on_its_car() -> None:
    cov = np.array([25.0 * np.eye(2)])
    name = GlobalName("a-t1-5", 5 * S)
    for member, own_xy, keeps in (("b", (0.0, 0.0), True), ("c", (500.0, 0.0), False)):
        names = GlobalNames(member)
        names.names = {3: name}  # named together while the cars drove together
        others = {"a": (2.0, 1.0), "b": (0.0, 0.0), "c": (500.0, 0.0)}
        del others[member]
        out = names.assign(20 * S, [3], np.array([own_xy]), cov, [_held_by(name.global_id, name.born_ns, others)])
        assert (out[3] == name) is keeps
        assert names.changes == (0 if keeps else 1)
        if not keeps:  # named anew, never after the name it gave up
            assert out[3] == GlobalName(f"{member}-t3-20", 20 * S)
    first = GlobalNames("a")  # the first holder keeps the name wherever the others are
    first.names = {1: name}
    assert first.assign(20 * S, [1], np.array([[2.0, 1.0]]), cov,
                        [_held_by(name.global_id, name.born_ns, {"c": (500.0, 0.0)})])[1] == name
