"""The federation as it runs: three daemons, three UAVs each, six cars, on a real Zenoh router (loopback).

``federation_city`` cuts the city in three vertical strips of 1000 m; ``west``, ``centre`` and ``east`` are each a
``gcs run`` process (``--federation city --member <team> --area <strip>``, a client of one ``gcs router``) beside
its team's ``sim-vehicles run`` process (``--only`` its three UAVs, under its prefix; one seed and one clock for the
three simulators, so the same cars; the truth published under ``west``, which flies the first vehicle). No MAVLink:
the vehicles loiter about their start points, and each team sees its strip and its neighbours' edges. The test
reads the members' ``MemberTracks`` from a Zenoh session of its own and tells which car a track is on by the truth.

1. every member hears the two others (``gcs status --federation city`` lists three; each daemon's counters);
2. car2, driving east along y = 900 m, keeps its global id when it crosses x = 1000 m: the id west holds it by
   before is the id centre, the receiving member, holds it by after;
3. centre is SIGKILLed: a target centre alone held (far from every track of the others) is searched for or held by
   another member within 5 s of data time, and the others count centre left (its liveliness token withdrawn);
   centre restarted with the same flags rejoins, and names the cars the federation already knows by their existing
   global ids, never by a name given before to another target;
4. the router is killed and restarted on its port: the members reconnect, count the others joined again, and go on
   publishing.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator

import pytest

from tests.e2e.processes import script
from tests.integration.federation_fleet import NS_PER_S, Fleet, Observer, Team, distance, track_on
from tests.integration.sim_harness import wait_until

SCENARIO = "federation_city"
FEDERATION = "city"
TEAMS = {"west": Team("west", "0,0,1000,3000", ("uav1", "uav2", "uav3")),
         "centre": Team("centre", "1000,0,2000,3000", ("uav4", "uav5", "uav6")),
         "east": Team("east", "2000,0,3000,3000", ("uav7", "uav8", "uav9"))}
SEED = 5
RATE = 4.0
"""Simulated seconds per wall second: the three daemons keep up on two cores (each fuses every decision step)."""
GATE_M = 100.0
"""A track within this distance of a car's truth (and nearer it than any other car) is a track on that car."""
APART_M = 300.0
"""A target centre alone holds, this far from every track of the others, cannot be taken for one of theirs."""
CAR2_CROSSES_S = 70.0
"""car2 drives from (300, 900) at t = 0 to (2700, 900) at t = 240 s: it crosses x = 1000 m at 70 s."""
WAIT_S = 90.0


@pytest.fixture
def fleet(tmp_path) -> Iterator[Fleet]:
    fleet = Fleet(SCENARIO, FEDERATION, TEAMS, SEED, RATE, tmp_path)
    try:
        yield fleet
    finally:
        fleet.close()
        print(fleet.report())  # shown when the test fails


@pytest.fixture
def running(fleet) -> Iterator[tuple[Fleet, Observer]]:
    """The router, the three members and their teams, and the test's observer; every one stopped on exit."""
    fleet.start_router()
    observer = Observer(fleet.endpoint, FEDERATION, truth_prefix="west")
    try:
        for team in TEAMS:
            fleet.start_daemon(team)
        start_at = time.time() + 5.0  # every simulator started by then, on a busy machine too
        for team in TEAMS:
            fleet.start_vehicles(team, start_at)
        yield fleet, observer
    finally:
        observer.close()


def _counter(observer: Observer, team: str, name: str) -> int:
    return observer.status(team).counters.get(name, 0)


def _stamp(observer: Observer, team: str) -> int:
    latest = observer.latest(team)
    return latest.stamp_ns if latest is not None else -1


def _held_on(observer: Observer, team: str, car: str, after_s: float, before_s: float = float("inf")) -> list[str]:
    """The global ids of the member's tracks on ``car`` in its messages stamped in (after_s, before_s), in order."""
    return [track.global_id for message in observer.of(team, int(after_s * NS_PER_S))
            if message.stamp_ns < before_s * NS_PER_S and (track := track_on(observer, message, car, GATE_M)) is not None]


def _centre_alone(observer: Observer) -> tuple[str, int] | None:
    """A global id centre's last four messages hold (so the others have taken it into their pictures) that neither
    other member's newest holds, far from all their tracks; with centre's newest stamp."""
    centre, others = observer.latest("centre"), [observer.latest(team) for team in ("west", "east")]
    if centre is None or None in others or any(abs(o.stamp_ns - centre.stamp_ns) > 2 * NS_PER_S for o in others):
        return None
    theirs = [track for message in others for track in message.tracks]
    held_a_while = set.intersection(*({t.global_id for t in m.tracks} for m in observer.of("centre")[-4:]))
    for track in centre.tracks:
        if track.global_id in held_a_while and all(t.global_id != track.global_id and distance(t, track.state[:2]) > APART_M for t in theirs):
            return track.global_id, centre.stamp_ns
    return None


def test_three_members_hand_over_a_car_survive_a_killed_member_and_a_restarted_router(running) -> None:
    fleet, observer = running

    # 1. Every member hears the two others.
    wait_until(lambda: all(len(observer.of(team)) >= 3 for team in TEAMS), WAIT_S, "every member's MemberTracks")
    status = subprocess.run([script("gcs"), "status", "--zenoh-mode", "client", "--zenoh-connect", fleet.endpoint,
                             "--federation", FEDERATION], capture_output=True, text=True, timeout=60)
    assert status.returncode == 0, status.stderr
    assert status.stdout.splitlines()[0] == "federation city: 3 members (centre, east, west)", status.stdout
    for team in TEAMS:
        counters = observer.status(team).counters
        assert counters.get("federation.joined", 0) >= 2 and counters.get("federation.heard", 0) >= 2, counters
        assert counters.get("rejected.federation", 0) == 0, counters

    # 2. car2 keeps its global id from west's strip into centre's.
    wait_until(lambda: _held_on(observer, "west", "car2", CAR2_CROSSES_S - 25, CAR2_CROSSES_S - 5)
               and _stamp(observer, "west") > (CAR2_CROSSES_S - 5) * NS_PER_S, WAIT_S, "west's track on car2")
    before = _held_on(observer, "west", "car2", CAR2_CROSSES_S - 25, CAR2_CROSSES_S - 5)[-1]
    wait_until(lambda: before in _held_on(observer, "centre", "car2", CAR2_CROSSES_S + 5), WAIT_S,
               f"centre to hold car2 by west's id {before} once it crossed x = 1000 m "
               f"(centre's ids on it: {_held_on(observer, 'centre', 'car2', CAR2_CROSSES_S + 5)})")

    # 3. centre dies: what it alone held is taken up; it comes back under the ids the federation knows.
    wait_until(lambda: _centre_alone(observer) is not None, WAIT_S, "a target centre alone holds")
    alone, _ = _centre_alone(observer)
    left_before = {team: _counter(observer, team, "federation.left") for team in ("west", "east")}
    joined_before = {team: _counter(observer, team, "federation.joined") for team in ("west", "east")}
    (centre,) = [p for name, p in fleet.processes.items() if name.startswith("gcs-run-centre")]
    centre.kill()
    centre.wait(timeout=30)
    died_at = observer.latest("centre").stamp_ns
    known_before = {track.global_id: track.born_ns for team in TEAMS for message in observer.of(team)
                    for track in message.tracks}

    def taken_up() -> list[tuple[str, int]]:
        return [(team, message.stamp_ns) for team in ("west", "east") for message in observer.of(team, died_at)
                if alone in message.searching or any(t.global_id == alone for t in message.tracks)]

    wait_until(taken_up, WAIT_S, f"{alone}, held by centre alone, to be searched for or held by another member")
    taker, taken_at = min(taken_up(), key=lambda row: row[1])
    assert taken_at - died_at <= 5 * NS_PER_S, (taker, taken_at, died_at)
    for team in ("west", "east"):
        wait_until(lambda: _counter(observer, team, "federation.left") > left_before[team], WAIT_S,
                   f"{team} to count centre left")

    restarted_at = _stamp(observer, "west")
    fleet.start_daemon("centre")
    for team in ("west", "east"):
        wait_until(lambda: _counter(observer, team, "federation.joined") > joined_before[team], WAIT_S,
                   f"{team} to count centre joined again")
    known_cars = {car for car in observer.cars() for team in TEAMS
                  if _held_on(observer, team, car, died_at / NS_PER_S - 20, died_at / NS_PER_S)}

    def named_again() -> dict[str, str]:
        """Each known car's first global id in the restarted centre's messages."""
        first: dict[str, str] = {}
        for message in observer.of("centre", restarted_at):
            for car in known_cars:
                track = track_on(observer, message, car, GATE_M)
                if track is not None:
                    first.setdefault(car, track.global_id)
        return first

    wait_until(lambda: len(named_again()) >= 2, WAIT_S, f"the restarted centre to track two of {known_cars}")
    assert set(named_again().values()) <= set(known_before), (named_again(), sorted(known_before))  # adopted
    reused = {(t.global_id, t.born_ns) for message in observer.of("centre", restarted_at) for t in message.tracks
              if t.global_id in known_before and t.born_ns != known_before[t.global_id]}
    assert not reused, reused  # a name is never given again to another target

    # 4. The router restarts on its port: the members reconnect and go on.
    joined_before = {team: _counter(observer, team, "federation.joined") for team in TEAMS}
    seq_before = {team: observer.latest(team).seq for team in TEAMS}
    (router,) = [p for name, p in fleet.processes.items() if name.startswith("router")]
    router.kill()
    router.wait(timeout=30)
    fleet.start_router()
    wait_until(lambda: all(observer.latest(team).seq > seq_before[team] + 5 for team in TEAMS), WAIT_S,
               "every member to publish again through the restarted router")
    for team in TEAMS:
        wait_until(lambda: _counter(observer, team, "federation.joined") >= joined_before[team] + 2, WAIT_S,
                   f"{team} to count the two others joined again")
        assert _counter(observer, team, "rejected.federation") == 0
    assert not observer.rejected, observer.rejected
