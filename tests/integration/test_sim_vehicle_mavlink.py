"""Simulated vehicles as MAVLink 2 peers, driven by a pymavlink ground station on loopback.

The ``ideal`` autopilot's command set (the arduplane and px4 personalities are tested in
tests/unit/test_sim_personalities.py and flown by the daemon's tests).
"""

from __future__ import annotations

import math

import pytest

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink, signing_key_from_passphrase
from tests.integration.sim_harness import IDEAL_SCENARIO, GroundStation, angle_error_deg, options, running_vehicles


GUIDED, LOITER = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"]


@pytest.fixture()
def link():
    gcs = GroundStation()
    with running_vehicles(options(gcs.port), IDEAL_SCENARIO) as runner:
        gcs.wait("HEARTBEAT")  # a udpin GCS learns where to send from the first packet
        yield gcs, runner
    gcs.close()


def test_every_vehicle_is_a_fixed_wing_with_its_own_sysid_on_one_port(link) -> None:
    gcs, _ = link
    for sysid in (1, 2, 3):
        beat = gcs.wait("HEARTBEAT", sysid)
        assert beat.type == mavlink.MAV_TYPE_FIXED_WING
        assert beat.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert beat.custom_mode == LOITER and beat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        assert beat.get_srcComponent() == 1
        assert gcs.wait("GPS_RAW_INT", sysid).fix_type >= 3
        position = gcs.wait("GLOBAL_POSITION_INT", sysid)
        assert abs(position.relative_alt / 1000.0 - (190.0 + 10.0 * sysid)) < 5.0
    assert gcs.conn.mavlink20()


def test_mode_change_is_acknowledged_and_addressed_to_one_vehicle(link) -> None:
    gcs, runner = link
    assert gcs.set_mode(2, GUIDED) == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.wait("HEARTBEAT", 2, condition=lambda m: m.custom_mode == GUIDED).custom_mode == GUIDED
    assert gcs.wait("HEARTBEAT", 1).custom_mode == LOITER
    assert gcs.set_mode(3, 99) == mavlink.MAV_RESULT_FAILED  # not a mode this vehicle has
    assert runner.autopilots["uav3"].mode == LOITER


def test_guided_change_heading_turns_the_vehicle_to_the_commanded_course(link) -> None:
    gcs, _ = link
    assert gcs.set_mode(2, GUIDED) == mavlink.MAV_RESULT_ACCEPTED
    gcs.command_int(2, mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, mavlink.MAV_FRAME_GLOBAL, (0, 45.0, 5.0))
    assert gcs.ack(2, mavlink.MAV_CMD_GUIDED_CHANGE_HEADING) == mavlink.MAV_RESULT_ACCEPTED
    gcs.wait("GLOBAL_POSITION_INT", 2, timeout=10.0,
             condition=lambda m: angle_error_deg(math.degrees(math.atan2(m.vy, m.vx)) % 360, 45.0) < 1.0)
    for _ in range(5):  # and it holds the course
        assert angle_error_deg(gcs.course_deg(2), 45.0) < 1.0


def test_position_target_carrot_steers_in_guided_and_is_ignored_outside(link) -> None:
    gcs, runner = link
    frame = runner.scene.frame

    def send_carrot(sysid: int, bearing_ned_deg: float) -> None:
        position = gcs.wait("GLOBAL_POSITION_INT", sysid)
        here = frame.to_enu(position.lat * 1e-7, position.lon * 1e-7, frame.height_m)
        ahead = math.radians(90.0 - bearing_ned_deg)  # ENU heading
        lat, lon, _ = frame.to_geodetic([here[0] + 1500 * math.cos(ahead), here[1] + 1500 * math.sin(ahead), 0.0])
        gcs.conn.mav.set_position_target_global_int_send(
            0, sysid, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0x09F8, int(lat * 1e7), int(lon * 1e7), 230.0,
            0, 0, 0, 0, 0, 0, math.radians(bearing_ned_deg), 0)

    loiter_before = runner.autopilots["uav1"].guidance
    send_carrot(1, 180.0)  # uav1 is in LOITER: dropped silently
    assert gcs.set_mode(3, GUIDED) == mavlink.MAV_RESULT_ACCEPTED
    for _ in range(40):  # re-sent like the daemon does, at about 4 Hz
        send_carrot(3, 180.0)
        if angle_error_deg(gcs.course_deg(3), 180.0) < 2.0:
            break
    assert angle_error_deg(gcs.course_deg(3), 180.0) < 2.0
    assert runner.autopilots["uav3"].guidance.altitude_m == 230.0
    assert gcs.wait("POSITION_TARGET_GLOBAL_INT", 3).coordinate_frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    assert runner.autopilots["uav1"].guidance == loiter_before
    assert runner.autopilots["uav1"].counters["position_target_outside_guided"] >= 1


def test_reposition_switches_to_guided_and_flies_to_the_point(link) -> None:
    gcs, runner = link
    frame = runner.scene.frame
    lat, lon, _ = frame.to_geodetic([500.0, 2600.0, 0.0])
    gcs.command_int(1, mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                    (-1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0), int(lat * 1e7), int(lon * 1e7), 250.0)
    assert gcs.ack(1, mavlink.MAV_CMD_DO_REPOSITION) == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.wait("HEARTBEAT", 1, condition=lambda m: m.custom_mode == GUIDED)

    def near(message) -> bool:
        enu = frame.to_enu(message.lat * 1e-7, message.lon * 1e-7, frame.height_m)
        return math.hypot(enu[0] - 500.0, enu[1] - 2600.0) < 200.0

    gcs.wait("GLOBAL_POSITION_INT", 1, timeout=15.0, condition=near)  # about 1700 m at 25 m/s, at 10x


def test_speed_altitude_and_information_requests(link) -> None:
    gcs, runner = link
    gcs.command_long(2, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 30.0, -1)
    assert gcs.ack(2, mavlink.MAV_CMD_DO_CHANGE_SPEED) == mavlink.MAV_RESULT_ACCEPTED
    gcs.wait("VFR_HUD", 2, timeout=10.0, condition=lambda m: abs(m.airspeed - 30.0) < 0.2)
    gcs.command_int(2, mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (), z=260.0)
    assert gcs.ack(2, mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE) == mavlink.MAV_RESULT_FAILED  # not in GUIDED
    assert gcs.set_mode(2, GUIDED) == mavlink.MAV_RESULT_ACCEPTED
    gcs.command_int(2, mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (), z=260.0)
    assert gcs.ack(2, mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE) == mavlink.MAV_RESULT_ACCEPTED
    gcs.wait("GLOBAL_POSITION_INT", 2, timeout=10.0, condition=lambda m: abs(m.relative_alt - 260_000) < 1000)

    gcs.command_long(3, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert gcs.ack(3, mavlink.MAV_CMD_REQUEST_MESSAGE) == mavlink.MAV_RESULT_ACCEPTED
    version = gcs.wait("AUTOPILOT_VERSION", 3)
    assert version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    gcs.command_long(3, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
    home = gcs.wait("HOME_POSITION", 3)
    assert home.latitude == round(runner.scene.frame.lat_deg * 1e7)
    gcs.conn.mav.param_request_list_send(3, 1)
    names = {gcs.wait("PARAM_VALUE", 3).param_id for _ in range(3)}
    assert names and all(isinstance(n, str) and n for n in names)
    gcs.conn.mav.mission_request_list_send(3, 1, mavlink.MAV_MISSION_TYPE_MISSION)
    assert gcs.wait("MISSION_COUNT", 3).count == 0
    gcs.command_long(3, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    assert gcs.ack(3, mavlink.MAV_CMD_COMPONENT_ARM_DISARM) == mavlink.MAV_RESULT_DENIED  # no disarm in flight
    gcs.command_long(3, 31999)
    assert gcs.ack(3, 31999) == mavlink.MAV_RESULT_UNSUPPORTED


def test_signed_vehicles_ignore_unsigned_commands_and_obey_signed_ones() -> None:
    key = signing_key_from_passphrase("correct horse")
    unsigned = GroundStation()
    port = unsigned.port
    try:
        with running_vehicles(options(port, signing_key=key)) as runner:
            unsigned.wait("HEARTBEAT", 1)
            unsigned.command_long(1, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            with pytest.raises(AssertionError):
                unsigned.ack(1, mavlink.MAV_CMD_DO_SET_MODE, timeout=2.0)
            assert runner.autopilots["uav1"].mode == LOITER
            signed_gcs = unsigned
            signed_gcs.conn.setup_signing(key, sign_outgoing=True)
            assert signed_gcs.set_mode(1, GUIDED) == mavlink.MAV_RESULT_ACCEPTED
            assert runner.autopilots["uav1"].mode == GUIDED
            assert signed_gcs.wait("HEARTBEAT", 1).get_signed()
    finally:
        unsigned.close()
