"""Two daemons of one federation on a real Zenoh router, on loopback.

``west`` and ``east`` (``--federation city``, the city split in two vertical strips) are clients of
one router, beside the simulated vehicles of ``multitarget_urban`` (no MAVLink: the vehicles fly
their own way). Both daemons fuse that one team's reports, so each holds tracks of the same cars;
what is checked is the federation's transport and what each member makes of the other:

* each daemon takes the other's ``MemberTracks`` into its picture (``federation.heard``), with the
  area the other was given, and counts it joined (its liveliness token);
* ``gcs status --federation city`` lists both members and the global tracks with their holders;
* ``east`` stops: ``west`` counts it left (its token withdrawn), and the cars ``east`` held in
  ``west``'s picture are held by ``west`` alone in its next pictures;
* ``west``'s recording, replayed with the same federation flags (``gcs replay --process
  --federation``), takes in the same members' messages as live and gives back west's tracks and its
  own federation messages bit for bit; ``gcs record --federation city``
  beside them records both members' tracks and tokens, east's withdrawn.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager

import pytest

from gcs.adapters.recording import read_recording
from gcs.adapters.zenoh_session import ZenohSettings, listening_endpoints, open_session
from gcs.config.world import build_world
from gcs.daemon.app import Daemon, DaemonOptions
from gcs.daemon.federation_status import format_federation, query_federation
from gcs.engine.federation import FederationOptions
from gcs.recordings.keys import key_kind
from gcs.recordings.record import RecordSettings, record
from gcs.recordings.replay import process
from gcs.scenarios import load_scenario
from protocols.codec import encode
from protocols.federation import MemberTracks
from sim_vehicles.run_options import RunOptions
from tests.integration.sim_harness import running_vehicles, wait_until
from tests.loopback import ANY_PORT_ENDPOINT

SCENARIO = load_scenario("multitarget_urban")
WORLD = build_world(SCENARIO)
FEDERATION = "city"
AREAS = {"west": (0.0, 0.0, 1500.0, 3000.0), "east": (1500.0, 0.0, 3000.0, 3000.0)}
RATE = 5.0


@pytest.fixture
def router() -> Iterator[str]:
    """A Zenoh router on a port the system chose; yields its endpoint."""
    session = open_session(ZenohSettings(mode="router", listen=(ANY_PORT_ENDPOINT,), connect=()))
    try:
        (endpoint,) = listening_endpoints(session)
        yield endpoint
    finally:
        session.close()


@contextmanager
def member(endpoint: str, member_id: str, **options) -> Iterator[tuple[Daemon, threading.Thread]]:
    """A daemon of the federation, a client of the router, running in a thread; stopped and joined on exit."""
    daemon = Daemon(SCENARIO, WORLD, DaemonOptions(
        zenoh=ZenohSettings(mode="client", connect=(endpoint,)), mavlink=None, plan_runner="thread",
        federation=FederationOptions(member_id, AREAS[member_id], prefix=FEDERATION), **options))
    daemon.open()
    thread = threading.Thread(target=daemon.run, name=f"daemon-{member_id}", daemon=True)
    thread.start()
    try:
        yield daemon, thread
    finally:
        daemon.stop()
        thread.join(timeout=15)
        assert not thread.is_alive(), f"daemon {member_id} did not stop"


def _holders(daemon: Daemon) -> tuple[int, set[str]]:
    """The stamp of the member's newest picture and every member holding one of its targets."""
    latest = daemon.engine.federation.latest
    if latest is None:
        return 0, set()
    return latest.picture.stamp_ns, {m for target in latest.picture.targets for m in target.holders}


def test_two_members_hear_each_other_and_one_that_stops_leaves_the_others_picture(router, tmp_path) -> None:
    recording, recorded = tmp_path / "west.mcap", tmp_path / "recorder.mcap"
    stop_recording = threading.Event()
    recorder = threading.Thread(target=record, args=(
        RecordSettings(ZenohSettings(mode="client", connect=(router,))), "gcs", recorded, stop_recording),
        kwargs={"announce": lambda line: None, "federation": FEDERATION}, daemon=True)
    recorder.start()
    with ExitStack() as stack:
        stack.callback(recorder.join, 15)
        stack.callback(stop_recording.set)
        west, _ = stack.enter_context(member(router, "west", record=recording))
        east, east_thread = stack.enter_context(member(router, "east"))
        stack.enter_context(running_vehicles(RunOptions(
            rate=RATE, seed=3, duration_s=120.0, epoch_ns=0, wait_for_subscriber_s=5,
            zenoh=ZenohSettings(mode="client", connect=(router,))), SCENARIO))
        pictures = {name: daemon.engine.federation.picture for name, daemon in (("west", west), ("east", east))}
        wait_until(lambda: "east" in pictures["west"].members and "west" in pictures["east"].members, 60,
                   "each member's MemberTracks in the other's picture")
        assert pictures["west"].members["east"].area_enu_m == AREAS["east"]
        assert pictures["east"].members["west"].area_enu_m == AREAS["west"]
        for daemon in (west, east):
            assert daemon.counters["federation.heard"] >= 1 and daemon.counters["federation.joined"] >= 1
            assert daemon.counters.get("rejected.federation", 0) == 0

        wait_until(lambda: {"west", "east"} <= _holders(west)[1], 60, "a car held by both members in west's picture")
        members = query_federation(ZenohSettings(mode="client", connect=(router,)), FEDERATION, 5.0)
        assert [m.member_id for m in members] == ["east", "west"]
        lines = format_federation(FEDERATION, members, members[0].stamp_ns)
        held = [line for line in lines if line.startswith("  global track") and "held by" in line]
        assert lines[0] == "federation city: 2 members (east, west)" and held, lines
        assert sum(len(m.tracks) for m in members) == sum(line.split("held by ")[1].split("  at")[0].count(",") + 1
                                                          for line in held)  # every member's track under its id

        east.stop()
        east_thread.join(timeout=15)
        assert not east_thread.is_alive()
        wait_until(lambda: west.counters["federation.left"] >= 1 and "east" not in pictures["west"].members, 30,
                   "west to see east leave")
        left_at = _holders(west)[0]
        wait_until(lambda: _holders(west)[0] > left_at, 30, "a picture of west's after east left")
        assert "east" not in _holders(west)[1]
    live = west.counters  # the daemon is closed: its counters are final

    # The recording holds the federation's messages and tokens; replayed as west, the engine takes in the same.
    kinds = {key_kind(r.key)[0] for r in read_recording(recording) if r.key.startswith(f"{FEDERATION}/federation/")}
    assert kinds == {"member", "member_alive"}
    assert not recorder.is_alive()
    tokens = [(key_kind(r.key)[1], r.payload) for r in read_recording(recorded) if key_kind(r.key)[0] == "member_alive"]
    members_recorded = {key_kind(r.key)[1] for r in read_recording(recorded) if key_kind(r.key)[0] == "member"}
    assert members_recorded == {"west", "east"} and ("east", b"gone") in tokens, tokens
    republished: list[MemberTracks] = []
    tracks, _, replayed = process(recording, SCENARIO, world=WORLD, plan=False,
                                  federation=FederationOptions("west", AREAS["west"], prefix=FEDERATION),
                                  member_tracks=republished)
    assert [replayed.get(name, 0) for name in ("federation.heard", "federation.joined", "federation.left")] == [
        live["federation.heard"], live["federation.joined"], live["federation.left"]]
    # ... and gives back west's tracks and its federation messages (global ids, lost targets searched) bit for bit.
    assert [encode(t)[0] for t in tracks] == [r.payload for r in read_recording(recording) if "/track/" in r.key]
    own = [r.payload for r in read_recording(recording) if key_kind(r.key) == ("member", "west")]
    assert len(own) >= 3 and [encode(m)[0] for m in republished] == own
