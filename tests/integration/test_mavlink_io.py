"""The daemon's MAVLink commander against the simulated vehicles and scripted peers, on 127.0.0.1."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator

import pytest

from gcs.adapters.mavlink_io import HeadingCommand, MavlinkCommander
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, GCS_SYSID, mavlink, sign_outgoing, signing_key_from_passphrase
from gcs.core.geometry import LocalFrame, wrap_angle
from sim_vehicles.mavlink_endpoint import SIGNING_EPOCH_S
from tests.integration.sim_harness import SCENARIO, GroundStation, options, running_vehicles


GUIDED, LOITER = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"]
FRAME = LocalFrame(SCENARIO.origin.lat_deg, SCENARIO.origin.lon_deg, SCENARIO.origin.height_m)
ROSTER = {v.id: v.sysid for v in SCENARIO.vehicles}
TURN_RATES = {v.id: v.max_turn_rate_rad_s for v in SCENARIO.vehicles}
KEY = signing_key_from_passphrase("correct horse")


def commander_on(port: int = 0, roster: dict[str, int] = ROSTER, scheme: str = "udpin",
                 **kwargs) -> MavlinkCommander:
    """A commander whose vehicles share one link (``udpin`` on port 0: the one the system chooses)."""
    return MavlinkCommander(FRAME, roster, dict.fromkeys(roster, f"{scheme}:127.0.0.1:{port}"),
                            max_turn_rate_rad_s=TURN_RATES, **kwargs)


def bound_port(commander: MavlinkCommander) -> int:
    """The port the system chose for the commander's one link."""
    (bound,) = set(commander.bound_connections().values())
    return int(bound.rsplit(":", 1)[1])


def pump(commander: MavlinkCommander, until: Callable[[], bool], timeout_s: float = 8.0) -> None:
    """Run the commander like the daemon (poll, service, wall clock) until ``until()``; AssertionError on timeout."""
    deadline = time.monotonic() + timeout_s
    while not until():
        now = time.monotonic()
        assert now < deadline, f"not reached within {timeout_s} s: {commander.counters()}"
        commander.poll(now)
        commander.service(now)
        time.sleep(0.005)


def course(commander: MavlinkCommander, vehicle_id: str) -> float | None:
    """Course over ground (ENU, rad) from the latest GLOBAL_POSITION_INT velocity."""
    velocity = commander.link(vehicle_id).velocity_enu_mps
    return None if velocity is None else math.atan2(velocity[1], velocity[0])


def on_course(commander: MavlinkCommander, vehicle_id: str, heading: float, tolerance_deg: float = 2.0) -> bool:
    now = course(commander, vehicle_id)
    return now is not None and abs(wrap_angle(now - heading)) < math.radians(tolerance_deg)


@pytest.fixture()
def sim() -> Iterator[tuple[MavlinkCommander, object]]:
    """The commander on ``udpin`` with the three simulated vehicles (10x real time) sending to it."""
    commander = commander_on()
    try:
        with running_vehicles(options(bound_port(commander))) as runner:
            pump(commander, lambda: all(commander.link(v).position_enu_m is not None for v in ROSTER))
            yield commander, runner
    finally:
        commander.close()


def test_every_vehicle_is_seen_where_the_simulation_has_it(sim) -> None:
    commander, runner = sim
    speed, sample_s = SCENARIO.vehicles[0].speed_mps, 1.0 / SCENARIO.simulation.telemetry_rate_hz
    for vehicle_id, sysid in ROSTER.items():
        commander.poll(time.monotonic())
        link = commander.link(vehicle_id)
        truth = runner.scene.vehicles[vehicle_id].state
        assert (link.sysid, link.autopilot, link.custom_mode, link.armed) == (sysid, 3, LOITER, True)
        assert commander.alive(vehicle_id, time.monotonic())
        # the telemetry is the truth, one sample (plus the wall-clock latency at 10x) behind
        assert math.dist(link.position_enu_m[:2], truth.position_enu_m[:2]) < speed * (sample_s + 0.5)
        assert link.position_enu_m[2] == pytest.approx(truth.position_enu_m[2], abs=1.0)
        assert math.hypot(*link.velocity_enu_mps[:2]) == pytest.approx(speed, abs=1.0)
        assert abs(wrap_angle(link.heading_enu_rad - truth.heading_rad)) < math.radians(10.0)  # loitering: turning
        assert link.counters["received"] > 0 and link.counters["link_up"] == 1
    assert commander.counters()["unknown_sysid"] == commander.counters()["bad_data"] == 0


def test_commanded_headings_switch_to_guided_and_the_courses_converge(sim) -> None:
    commander, runner = sim
    wanted = {vid: float(wrap_angle(course(commander, vid) + math.radians(120.0))) for vid in ROSTER}
    for vehicle_id, heading in wanted.items():
        commander.command(vehicle_id, HeadingCommand(heading, 230.0, 25.0))
    start_s, converged_s = runner.scene.elapsed_s, {}

    def all_converged() -> bool:
        for vid, heading in wanted.items():
            if vid not in converged_s and on_course(commander, vid, heading):
                converged_s[vid] = runner.scene.elapsed_s - start_s
        return len(converged_s) == len(wanted)

    pump(commander, all_converged)
    assert max(converged_s.values()) < 30.0, converged_s  # simulated seconds, for a 120 degree turn at 0.2 rad/s
    pump(commander, lambda: runner.scene.elapsed_s > start_s + max(converged_s.values()) + 5.0)
    for vehicle_id, heading in wanted.items():
        link = commander.link(vehicle_id)
        assert on_course(commander, vehicle_id, heading), vehicle_id  # and holds it
        assert link.custom_mode == GUIDED and runner.autopilots[vehicle_id].mode == GUIDED
        assert link.counters["mode_requests"] >= 1 and link.counters["carrots"] == 0  # ArduPilot: no carrots
        assert link.counters["stream_requests"] >= 2 and link.counters["streams_below_rate"] == 0
        assert link.last_ack[mavlink.MAV_CMD_DO_SET_MODE] == mavlink.MAV_RESULT_ACCEPTED
        assert link.last_ack[mavlink.MAV_CMD_GUIDED_CHANGE_HEADING] == mavlink.MAV_RESULT_ACCEPTED
        assert link.position_enu_m[2] == pytest.approx(230.0, abs=5.0)  # climbing from 200-220 m at 5 m/s max


def test_guided_change_heading_is_sent_once_per_change(sim) -> None:
    commander, runner = sim
    uav = "uav2"
    commands = runner.autopilots[uav].counters  # COMMAND_INT received by the vehicle: heading, speed, altitude
    commander.command(uav, HeadingCommand(1.0, 220.0, 25.0))
    pump(commander, lambda: commander.link(uav).counters["heading_commands"] == 1 and commands["COMMAND_INT"] == 3)
    for jitter in (0.001, -0.002, 0.003, 0.0):  # radians, all below 0.5 degree
        commander.command(uav, HeadingCommand(1.0 + jitter, 220.0, 25.0))
        pump(commander, lambda c=commander.link(uav).counters["received"]: commander.link(uav).counters["received"] > c + 5)
    assert commander.link(uav).counters["heading_commands"] == 1 and commands["COMMAND_INT"] == 3
    commander.command(uav, HeadingCommand(1.5, 220.0, 25.0))
    pump(commander, lambda: on_course(commander, uav, 1.5))
    link = commander.link(uav)
    assert (link.counters["heading_commands"], link.counters["speed_commands"], link.counters["altitude_commands"]) \
        == (2, 1, 1)
    assert commands["COMMAND_INT"] == 4
    assert commander.counters()["heading_commands"] == 2  # the other vehicles were never commanded
    assert commander.link("uav1").counters["mode_requests"] == 0 and runner.autopilots["uav1"].mode == LOITER


def test_signed_commander_flies_signed_vehicles() -> None:
    commander = commander_on(signing_key=KEY)
    try:
        with running_vehicles(options(bound_port(commander), signing_key=KEY)) as runner:
            commander.command("uav3", HeadingCommand(0.0, 220.0, 25.0))
            pump(commander, lambda: on_course(commander, "uav3", 0.0))
            assert runner.autopilots["uav3"].mode == GUIDED  # the vehicles drop unsigned commands
            assert commander.counters()["bad_signature"] == 0
            assert all(commander.link(v).counters["received"] > 0 for v in ROSTER)
    finally:
        commander.close()


# --------------------------------------------------- scripted peers on a synthetic clock


class ScriptedVehicles:
    """A udpin socket the commander reaches by ``udpout``, speaking as vehicles the test scripts."""

    def __init__(self, signing_key: bytes | None = None) -> None:
        self.station = GroundStation(0, signing_key)  # receives (and with a key, checks signatures)
        self.signing_key = signing_key
        self.encoders: dict[int, mavlink.MAVLink] = {}

    def hear(self, commander: MavlinkCommander):
        """The commander's first GCS HEARTBEAT, which tells this socket where the commander is."""
        commander.service(0.0)
        return self.station.wait("HEARTBEAT", GCS_SYSID, timeout=3.0)

    def encoder(self, sysid: int) -> mavlink.MAVLink:
        if sysid not in self.encoders:
            self.encoders[sysid] = mavlink.MAVLink(self.station.conn, srcSystem=sysid, srcComponent=1)
            if self.signing_key is not None:
                timestamp = int((time.time() - SIGNING_EPOCH_S) * 1e5)
                sign_outgoing(self.encoders[sysid], self.signing_key, sysid, timestamp)
        return self.encoders[sysid]

    def heartbeat(self, sysid: int, custom_mode: int = GUIDED) -> None:
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        self.encoder(sysid).heartbeat_send(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                           custom_mode, mavlink.MAV_STATE_ACTIVE)

    def position(self, sysid: int) -> None:
        lat, lon, _ = FRAME.to_geodetic([100.0, 200.0, 200.0])
        self.encoder(sysid).global_position_int_send(0, round(float(lat) * 1e7), round(float(lon) * 1e7),
                                                     250_000, 200_000, 2500, 0, 0, 0)

    def close(self) -> None:
        self.station.close()


def settle(commander: MavlinkCommander, now_s: float, until: Callable[[], bool], timeout_s: float = 3.0) -> None:
    """Poll at the synthetic time ``now_s`` until the datagrams in flight have made ``until()`` true."""
    deadline = time.monotonic() + timeout_s
    while not until():
        assert time.monotonic() < deadline, f"not reached: {commander.counters()}"
        commander.poll(now_s)
        time.sleep(0.002)


@pytest.fixture()
def scripted() -> Iterator[tuple[MavlinkCommander, ScriptedVehicles]]:
    peers = ScriptedVehicles()
    commander = commander_on(peers.station.port, {"uav1": 1, "uav2": 2}, scheme="udpout")
    try:
        peers.first_heartbeat = peers.hear(commander)
        yield commander, peers
    finally:
        commander.close()
        peers.close()


def test_writing_on_udpin_before_any_packet_is_counted_not_sent() -> None:
    commander = commander_on()
    try:
        commander.service(0.0)
        commander.service(1.0)
        counters = commander.counters()
        assert counters["no_destination"] == 2 and counters["sent"] == 0
        assert not commander.alive("uav1", 1.0) and commander.link("uav1").position_enu_m is None
    finally:
        commander.close()


def test_gcs_heartbeat_unknown_sysids_bad_data_and_a_vehicle_that_never_appears(scripted) -> None:
    commander, peers = scripted
    beat = peers.first_heartbeat
    assert (beat.type, beat.autopilot, beat.get_srcComponent()) == (mavlink.MAV_TYPE_GCS,
                                                                     mavlink.MAV_AUTOPILOT_INVALID, 190)
    peers.heartbeat(9)  # not in the roster
    peers.station.conn.write(b"not mavlink at all")
    peers.heartbeat(1)
    settle(commander, 0.5, lambda: commander.alive("uav1", 0.5))
    counters = commander.counters()
    assert counters["unknown_sysid"] == 1 and counters["bad_data"] >= 1
    commander.command("uav2", HeadingCommand(0.0, 200.0, 25.0))  # uav2 never appears: nothing goes to it
    for now in (1.0, 2.0, 3.0):
        commander.service(now)
    assert commander.link("uav2").counters["sent"] == 0 and commander.counters()["gcs_heartbeats"] == 4


def test_a_vehicle_that_disappears_and_returns_gets_its_heading_again(scripted, caplog) -> None:
    commander, peers = scripted
    station = peers.station
    peers.heartbeat(1)
    peers.position(1)
    settle(commander, 0.0, lambda: commander.link("uav1").position_enu_m is not None)
    commander.command("uav1", HeadingCommand(math.radians(30.0), 200.0, 25.0))
    commander.service(0.1)
    streams = station.wait("COMMAND_LONG", GCS_SYSID, condition=lambda m: m.command == 511)  # sent first
    assert (streams.target_system, streams.param1, streams.param2) == (1, 33.0, 200_000.0)  # 5 Hz positions
    heading = station.wait("COMMAND_INT", GCS_SYSID, condition=lambda m: m.command == 43002)
    assert (heading.target_system, heading.param1, heading.param2) == (1, 0.0, pytest.approx(60.0))
    assert heading.param3 == pytest.approx(1.25 * 25.0 * TURN_RATES["uav1"])
    for now in (1.0, 2.0, 3.0):  # heard every second, same command: no new heading command
        peers.heartbeat(1)
        settle(commander, now, lambda t=now: commander.link("uav1").last_heartbeat_s == t)
        commander.service(now)
    link = commander.link("uav1")
    assert link.counters["heading_commands"] == 1 and link.counters["link_up"] == 1

    with caplog.at_level(logging.WARNING, logger="gcs.adapters.mavlink_io"):
        commander.service(9.0)  # silent for 6 s: lost, nothing sent to it
        assert link.counters["link_lost"] == 1 and not commander.alive("uav1", 9.0)
        requests = link.counters["stream_requests"]
        peers.heartbeat(1)  # back
        settle(commander, 10.0, lambda: commander.alive("uav1", 10.0))
        commander.service(10.0)
        assert link.counters["link_up"] == 2 and link.counters["heading_commands"] == 2
        assert link.counters["stream_requests"] == requests + 2  # the rates are asked for again
        assert link.counters["carrots"] == 0

        peers.heartbeat(1, LOITER)  # switched away (a pilot, a failsafe): GUIDED is requested again
        settle(commander, 10.5, lambda: link.custom_mode == LOITER)
        commander.service(11.0)
        assert station.wait("COMMAND_LONG", GCS_SYSID, condition=lambda m: m.command == 176).param2 == GUIDED
        peers.encoder(1).command_ack_send(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_RESULT_DENIED, 0, 0,
                                          GCS_SYSID, 190)
        settle(commander, 11.0, lambda: link.counters["commands_rejected"] == 1)
        peers.heartbeat(1, GUIDED)
        settle(commander, 11.5, lambda: link.custom_mode == GUIDED)
        commander.service(11.5)
    assert link.counters["heading_commands"] == 3  # re-sent after the return to GUIDED
    assert link.counters["ack_denied"] == 1 and link.last_ack[mavlink.MAV_CMD_DO_SET_MODE] == mavlink.MAV_RESULT_DENIED
    assert any("uav1 rejected MAV_CMD_DO_SET_MODE" in r.getMessage() for r in caplog.records)
    assert any("no HEARTBEAT" in r.getMessage() for r in caplog.records)


def test_a_signing_commander_rejects_unsigned_vehicles_and_signs_what_it_sends() -> None:
    signed_peers = ScriptedVehicles(signing_key=KEY)
    commander = commander_on(signed_peers.station.port, {"uav1": 1, "uav2": 2}, scheme="udpout", signing_key=KEY)
    try:
        assert signed_peers.hear(commander).get_signed()  # the station drops unsigned messages
        unsigned = mavlink.MAVLink(signed_peers.station.conn, srcSystem=2, srcComponent=1)
        unsigned.heartbeat_send(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, GUIDED, 4)
        settle(commander, 0.5, lambda: commander.counters()["bad_signature"] == 1)
        signed_peers.heartbeat(1)
        settle(commander, 0.5, lambda: commander.alive("uav1", 0.5))
        assert not commander.alive("uav2", 0.5) and commander.link("uav2").counters["received"] == 0
    finally:
        commander.close()
        signed_peers.close()
