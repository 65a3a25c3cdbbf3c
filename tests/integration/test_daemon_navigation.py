"""The daemon's own navigation of the vehicles (--navigation skf) live, through a GPS-denied strip, and its replay.

The daemon runs in a thread against the simulated vehicles (a thread too) on loopback, on
the shipped ``wang2012_gps_denied`` scenario, recording what it receives and publishes.
Each vehicle's position covariance grows while it flies without GPS and shrinks when the
fix returns; ``gcs replay --process`` of the recording gives back the daemon's tracks bit
for bit.
"""

from __future__ import annotations

from gcs.adapters.recording import read_recording
from gcs.config.world import build_world
from gcs.core.navigation.skf import MIN_GPS_FIX
from gcs.recordings.replay import key_kind, process
from gcs.scenarios import load_scenario
from protocols.codec import decode, encode
from protocols.messages import NavReport
from tests.integration.daemon_flight import daemon_through_a_flight

SCENARIO = load_scenario("wang2012_gps_denied")
WORLD = build_world(SCENARIO)
RATE = 5.0
DURATION_S = 100.0
"""Some vehicle flies into the strip and out well within it: its first entry has come 10-56 s in, by the live loop's
timing."""
EPOCH_NS = 1_000_000_000_000


def _fixes_per_step(recording, records, vehicle: str) -> list[frozenset[bool]]:
    """For each step record, whether the vehicle's nav reports the step applied had a GPS fix.

    Read from the recorded wire traffic: step ``k`` applies the reports stamped in
    ``(T_{k-1}, T_k]`` (``FleetNavigator.advance_to``). ``{True}``: every one had a fix,
    ``{False}``: none had, both: the vehicle crossed the strip's edge during the step.
    """
    stamps = []
    for recorded in read_recording(recording):
        if key_kind(recorded.key) == ("nav", vehicle):
            nav = decode(recorded.payload, recorded.encoding, NavReport)
            stamps.append((nav.stamp_ns, nav.gps is not None and nav.gps.fix_type >= MIN_GPS_FIX))
    fixes, previous = [], -1
    for record in records:
        fixes.append(frozenset(fix for stamp, fix in stamps if previous < stamp <= record.stamp_ns))
        previous = record.stamp_ns
    return fixes


def _no_fix_runs(fixes: list[frozenset[bool]]) -> list[tuple[int, int, int]]:
    """(first, last, back) record indices of each run of steps flown wholly without GPS.

    ``first..last`` is the run (a step with a fix before it), ``back`` the first step after it
    with a fix on every report.
    """
    runs, start = [], None
    for i, step in enumerate(fixes):
        if step == {False} and start is None and i > 0 and True in fixes[i - 1]:
            start = i
        elif step != {False} and start is not None:
            back = next((j for j in range(i, len(fixes)) if fixes[j] == {True}), None)
            if back is not None:
                runs.append((start, i - 1, back))
            start = None
    return runs


def test_the_daemon_navigates_through_a_gps_denied_strip_and_replay_reproduces_its_tracks(tmp_path) -> None:
    recording = tmp_path / "run.mcap"
    with daemon_through_a_flight(SCENARIO, WORLD, recording, seed=3, duration_s=DURATION_S, rate=RATE,
                                 epoch_ns=EPOCH_NS) as (daemon, _):
        assert daemon.options.navigation == "auto" and daemon.navigator is not None  # the default, on GPS-denied zones
        status = daemon.status(0.0)
    counters = status.counters
    assert counters.get("errors.decision", 0) == 0 and counters.get("rejected.nav_update", 0) == 0
    # The navigator's state at a step is a function of the reports' stamps when none arrived late.
    assert counters.get("rejected.late", 0) == 0 and counters.get("rejected.late_nav", 0) == 0, counters
    records = daemon.records
    runs = {v: _no_fix_runs(_fixes_per_step(recording, records, v)) for v in daemon.roster}
    assert any(runs.values()), f"no vehicle flew through the strip and out: {[r.gps_fix for r in records]}"
    for vehicle, vehicle_runs in runs.items():
        for first, last, back in vehicle_runs:
            std = [records[i].nav_std_m[vehicle] for i in range(first - 1, back + 1)]
            run = std[: last - first + 2]  # the step before the run, then the run: dead reckoning, growing step by step
            assert all(b > a for a, b in zip(run, run[1:])), (vehicle, std)
            assert std[-1] < max(std[:-1]), (vehicle, std)  # shrinks once the fix is back
            assert not records[last].gps_fix[vehicle] and records[back].gps_fix[vehicle], (vehicle, first, last, back)
    seen = sum(any(r.seen.values()) for r in records)
    assert seen >= 0.8 * len(records)

    # The recording gives back the daemon's tracks bit for bit (nothing arrived late, the condition).
    live = [r.payload for r in read_recording(recording) if "/track/" in r.key]
    tracks, _, replay_counters = process(recording, SCENARIO)
    assert len(live) >= DURATION_S - 5 and [encode(t)[0] for t in tracks] == live
    assert replay_counters["nav.applied"] > 0 and replay_counters.get("rejected.late_nav", 0) == 0
