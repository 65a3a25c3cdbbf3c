"""The MAVLink adapter's pure parts: carrot geometry, telemetry conversions, what is sent when."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.adapters.mavlink_commands import SendMemory, carrot_distance_m, carrot_for, due_actions
from gcs.adapters.mavlink_messages import (CARROT_TYPE_MASK, Carrot, ChangeAltitude, ChangeHeading, ChangeSpeed,
                                           MessageInterval, ModeRequest, course_param_deg)
from gcs.adapters.mavlink_takeover import Takeover
from gcs.adapters.mavlink_io import MavlinkCommander
from gcs.adapters.mavlink_link import HeadingCommand, VehicleLink, in_guided_mode, update_from_message
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, GCS_SYSID, mavlink
from gcs.core.geometry import LocalFrame, wrap_angle

FRAME = LocalFrame(28.22, 112.99, 50.0)
GUIDED, LOITER = ARDUPLANE_MODES["GUIDED"], ARDUPLANE_MODES["LOITER"]
ARDUPILOT, PX4 = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, mavlink.MAV_AUTOPILOT_PX4
TURN_RATE = 0.2
CARROT_PERIOD = 0.25

headings = st.floats(-math.pi, math.pi)
coordinates = st.floats(-3000.0, 3000.0)


def roundtrip(message, sysid: int = 1):
    """``message`` packed by vehicle ``sysid`` and decoded again, as a receiver sees it."""
    encoder = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1)
    return mavlink.MAVLink(None).decode(bytearray(message.pack(encoder)))


def flying(autopilot: int = ARDUPILOT, mode: int = GUIDED, heading_deg: float = 90.0, **command) -> VehicleLink:
    """A vehicle heard at t = 0, at (1200, 1300, 200) m, flying east at 25 m/s, with a command."""
    wanted = {"heading_enu_rad": math.radians(heading_deg), "altitude_m": 220.0, "airspeed_mps": 25.0} | command
    return VehicleLink("uav1", 1, autopilot=autopilot, custom_mode=mode, armed=True, last_heartbeat_s=0.0,
                       position_enu_m=np.array([1200.0, 1300.0, 200.0]), velocity_enu_mps=np.array([25.0, 0.0, 0.0]),
                       heading_enu_rad=0.0, position_stamp_s=0.0, command=HeadingCommand(**wanted))


def due(link: VehicleLink, memory: SendMemory, now_s: float, stream_rate_hz: float = 0.0):
    return due_actions(FRAME, link, memory, now_s, max_turn_rate_rad_s=TURN_RATE, carrot_period_s=CARROT_PERIOD,
                       link_timeout_s=5.0, stream_rate_hz=stream_rate_hz)


OFFBOARD = 6 << 16


def kinds(actions) -> list[type]:
    return [type(a) for a in actions]


# ---------------------------------------------------------------- carrot geometry


@pytest.mark.parametrize(("speed", "rate", "expected"), [
    (25.0, 0.2, 375.0),    # 3 turn radii = 15 s of flight
    (25.0, 0.05, 1500.0),  # a wide turn: 3 x 500 m radius
    (10.0, 1.0, 150.0),    # a tight turn: 15 s at 10 m/s
])
def test_carrot_distance_is_the_larger_of_three_turn_radii_and_15_s(speed: float, rate: float, expected: float) -> None:
    assert carrot_distance_m(speed, rate) == pytest.approx(expected)


@given(headings, coordinates, coordinates, st.floats(100.0, 400.0))
def test_carrot_lies_the_carrot_distance_along_the_commanded_heading(heading: float, x: float, y: float,
                                                                      altitude: float) -> None:
    link = flying(heading_deg=math.degrees(heading), altitude_m=altitude)
    link.position_enu_m = np.array([x, y, 150.0])
    carrot = carrot_for(FRAME, link, link.command, TURN_RATE, now_s=12.5)
    back = FRAME.to_enu(carrot.lat_e7 * 1e-7, carrot.lon_e7 * 1e-7, FRAME.height_m + carrot.altitude_m)
    offset = back[:2] - np.array([x, y])
    assert np.hypot(*offset) == pytest.approx(375.0, abs=0.05)  # 1e-7 degree is about 1 cm
    assert abs(wrap_angle(math.atan2(offset[1], offset[0]) - heading)) < 1e-3
    assert carrot.altitude_m == altitude
    assert math.sin(carrot.yaw_ned_rad) == pytest.approx(math.cos(heading), abs=1e-9)  # NED yaw: east = sin
    assert math.cos(carrot.yaw_ned_rad) == pytest.approx(math.sin(heading), abs=1e-9)
    assert carrot.time_boot_ms == 12_500


def test_carrot_distance_grows_with_a_ground_speed_above_the_airspeed() -> None:
    link = flying(heading_deg=90.0)  # north
    link.velocity_enu_mps = np.array([0.0, 30.0, 0.0])  # tail wind
    carrot = carrot_for(FRAME, link, link.command, TURN_RATE, now_s=0.0)
    back = FRAME.to_enu(carrot.lat_e7 * 1e-7, carrot.lon_e7 * 1e-7, FRAME.height_m + carrot.altitude_m)
    np.testing.assert_allclose(back[:2], [1200.0, 1300.0 + 450.0], atol=0.05)


def test_carrot_message_fields() -> None:
    link = flying(heading_deg=180.0)
    carrot = carrot_for(FRAME, link, link.command, TURN_RATE, now_s=1.0)
    sent = roundtrip(carrot.encode(mavlink.MAVLink(None, srcSystem=GCS_SYSID), 7), sysid=GCS_SYSID)
    assert sent.get_type() == "SET_POSITION_TARGET_GLOBAL_INT"
    assert (sent.target_system, sent.target_component) == (7, 1)
    assert sent.coordinate_frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    assert sent.type_mask == CARROT_TYPE_MASK == 2552
    assert (sent.lat_int, sent.lon_int, sent.alt) == (carrot.lat_e7, carrot.lon_e7, 220.0)
    assert sent.yaw == pytest.approx(-math.pi / 2)  # ENU west is NED -90 degrees


# ---------------------------------------------------------------- telemetry in


def test_global_position_int_becomes_enu_position_velocity_and_heading() -> None:
    truth = np.array([812.3, -415.9, 205.25])
    lat, lon, _ = FRAME.to_geodetic(truth)
    message = roundtrip(mavlink.MAVLink_global_position_int_message(
        1000, round(float(lat) * 1e7), round(float(lon) * 1e7), 255_250, 205_250, 100, 200, 50, 9000))
    link = VehicleLink("uav1", 1)
    assert update_from_message(link, message, 42.0, FRAME) is None
    np.testing.assert_allclose(link.position_enu_m, truth, atol=0.02)
    np.testing.assert_allclose(link.velocity_enu_mps, [2.0, 1.0, -0.5])  # NED (1, 2, 0.5) m/s
    assert link.heading_enu_rad == pytest.approx(0.0)  # hdg 90 degrees: east
    assert link.position_stamp_s == 42.0


@pytest.mark.parametrize(("hdg_cdeg", "enu"),
                         [(0, math.pi / 2), (18000, -math.pi / 2), (27000, math.pi), (4500, math.pi / 4)])
def test_hdg_in_centidegrees_ned_becomes_enu(hdg_cdeg: int, enu: float) -> None:
    link = VehicleLink("uav1", 1)
    position = mavlink.MAVLink_global_position_int_message(0, 282200000, 1129900000, 0, 0, 0, 0, 0, hdg_cdeg)
    update_from_message(link, position, 0.0, FRAME)
    assert wrap_angle(link.heading_enu_rad - enu) == pytest.approx(0.0, abs=1e-9)


def test_unknown_hdg_keeps_the_attitude_yaw() -> None:
    link = VehicleLink("uav1", 1)
    update_from_message(link, roundtrip(mavlink.MAVLink_attitude_message(0, 0.1, 0.0, math.pi, 0, 0, 0)), 0.0, FRAME)
    assert link.heading_enu_rad == pytest.approx(-math.pi / 2)  # NED yaw pi: south
    update_from_message(link, mavlink.MAVLink_global_position_int_message(0, 0, 0, 0, 0, 0, 0, 0, 65535), 1.0, FRAME)
    assert link.heading_enu_rad == pytest.approx(-math.pi / 2)


def test_vehicle_heartbeats_count_and_ground_station_heartbeats_do_not() -> None:
    link = VehicleLink("uav1", 1)
    gcs = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    assert update_from_message(link, gcs, 1.0, FRAME) is None
    assert link.last_heartbeat_s is None and not link.alive(1.0, 5.0)
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    plane = roundtrip(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_FIXED_WING, ARDUPILOT, base, GUIDED, 4, 3))
    assert update_from_message(link, plane, 2.0, FRAME) == "heartbeat"
    assert (link.autopilot, link.custom_mode, link.armed, link.mode_name) == (ARDUPILOT, GUIDED, True, "GUIDED")
    assert link.alive(7.0, 5.0) and not link.alive(7.1, 5.0)


def test_guided_means_offboard_for_px4_and_mode_15_otherwise() -> None:
    assert in_guided_mode(ARDUPILOT, GUIDED) and not in_guided_mode(ARDUPILOT, LOITER)
    assert in_guided_mode(PX4, 6 << 16) and not in_guided_mode(PX4, GUIDED)
    assert not in_guided_mode(None, None)


# ---------------------------------------------------------------- what is sent when


def test_first_service_to_ardupilot_in_guided_sends_heading_speed_and_altitude_and_no_carrot() -> None:
    actions, memory = due(flying(heading_deg=30.0), SendMemory(), 0.0)
    assert kinds(actions) == [ChangeHeading, ChangeSpeed, ChangeAltitude]
    heading = actions[0]
    assert heading.course_deg == pytest.approx(60.0)  # ENU 30 degrees = NED 60 degrees
    assert heading.lateral_accel_mps2 == pytest.approx(1.25 * 25.0 * TURN_RATE)  # the bank margin over V omega
    assert (actions[1].airspeed_mps, actions[2].altitude_m) == (25.0, 220.0)
    assert memory.heading_rad == pytest.approx(math.radians(30.0)) and memory.next_carrot_s == -math.inf


def test_px4_in_offboard_gets_only_carrots_along_the_commanded_course() -> None:
    link = flying(autopilot=PX4, mode=OFFBOARD, heading_deg=-45.0)
    actions, _ = due(link, SendMemory(), 0.0)
    assert kinds(actions) == [Carrot]
    assert actions[0].yaw_ned_rad == pytest.approx(math.radians(135.0))  # ENU -45 degrees = NED 135 degrees


def test_guided_change_heading_only_when_the_heading_moves_more_than_half_a_degree() -> None:
    link = flying(heading_deg=359.8)
    sent = []
    memory = SendMemory()
    for step, (heading_deg, altitude, airspeed) in enumerate([
            (359.8, 220.0, 25.0),   # first: all three
            (359.8, 220.0, 25.0),   # unchanged: none
            (0.1, 220.0, 25.0),     # 0.3 degree across the wrap: none
            (0.4, 220.3, 25.05),    # 0.6 degree: heading only (altitude and speed within tolerance)
            (0.4, 221.0, 25.05),    # 0.7 m: altitude only
            (0.4, 221.0, 27.0)]):   # speed only
        link.command = HeadingCommand(math.radians(heading_deg), altitude, airspeed)
        actions, memory = due(link, memory, step * 0.1)
        sent.append([type(a) for a in actions if not isinstance(a, Carrot)])
    assert sent == [[ChangeHeading, ChangeSpeed, ChangeAltitude], [], [], [ChangeHeading], [ChangeAltitude],
                    [ChangeSpeed]]
    actions, _ = due(link, memory.forget_guided(), 1.0)  # re-entered GUIDED, or the link came back
    assert kinds(actions) == [ChangeHeading, ChangeSpeed, ChangeAltitude]


def test_mode_requests_at_most_once_per_second_and_no_guided_commands_outside_guided() -> None:
    link = flying(mode=LOITER)
    memory, requests = SendMemory(), []
    for now in np.arange(0.0, 3.05, 0.1):
        actions, memory = due(link, memory, float(now))
        assert not {ChangeHeading, ChangeSpeed, ChangeAltitude} & set(kinds(actions))
        requests += [round(float(now), 1) for a in actions if isinstance(a, ModeRequest)]
    assert requests == [0.0, 1.0, 2.0, 3.0]
    link.custom_mode = GUIDED
    actions, _ = due(link, memory, 3.5)
    assert ModeRequest not in kinds(actions) and ChangeHeading in kinds(actions)


def test_px4_is_asked_for_offboard_and_gets_no_ardupilot_commands() -> None:
    actions, memory = due(flying(autopilot=PX4, mode=0), SendMemory(), 0.0)
    assert kinds(actions) == [Carrot, ModeRequest] and actions[1].custom_mode == 6
    actions, _ = due(flying(autopilot=PX4, mode=OFFBOARD), memory, 2.0)
    assert kinds(actions) == [Carrot]


def test_mode_request_message_fields() -> None:
    sent = roundtrip(ModeRequest(GUIDED).encode(mavlink.MAVLink(None, srcSystem=GCS_SYSID), 3), sysid=GCS_SYSID)
    assert (sent.get_type(), sent.command, sent.target_system, sent.target_component) == ("COMMAND_LONG", 176, 3, 1)
    assert (sent.param1, sent.param2) == (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15.0)


def test_guided_command_message_fields() -> None:
    encoder = mavlink.MAVLink(None, srcSystem=GCS_SYSID)
    heading = roundtrip(ChangeHeading(271.5, 5.0).encode(encoder, 2), sysid=GCS_SYSID)
    assert (heading.command, heading.param1, heading.param2, heading.param3) == (43002, 0.0, 271.5, 5.0)
    speed = roundtrip(ChangeSpeed(28.0).encode(encoder, 2), sysid=GCS_SYSID)
    assert (speed.command, speed.param1, speed.param2) == (43000, 0.0, 28.0)
    altitude = roundtrip(ChangeAltitude(240.0).encode(encoder, 2), sysid=GCS_SYSID)
    assert (altitude.command, altitude.frame, altitude.z) == (43001, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, 240.0)
    assert heading.target_system == speed.target_system == altitude.target_system == 2


@given(headings)
def test_course_parameter_is_in_0_360_as_float32(heading: float) -> None:
    degrees = course_param_deg(heading)
    assert 0.0 <= np.float32(degrees) < 360.0
    assert abs(wrap_angle(math.radians(degrees) - (math.pi / 2 - heading))) < 1e-9  # NED = pi/2 - ENU


def test_course_parameter_just_below_north() -> None:
    assert course_param_deg(math.pi / 2 + 1e-12) == 0.0  # 359.99999999994 would be 360.0 as float32


def test_carrots_stream_at_the_carrot_rate_and_wait_for_a_position() -> None:
    link = flying(autopilot=PX4, mode=OFFBOARD)
    memory, carrots = SendMemory(), 0
    for now in np.arange(0.0, 10.0, 0.01):
        link.last_heartbeat_s = float(now)
        actions, memory = due(link, memory, float(now))
        carrots += kinds(actions).count(Carrot)
    assert carrots == 40  # 4 Hz for 10 s, drift-free
    link.position_enu_m = None
    actions, _ = due(link, SendMemory(), 0.0)
    assert actions == []


def test_a_stall_does_not_cause_a_burst_of_carrots() -> None:
    link = flying(autopilot=PX4, mode=OFFBOARD)
    _, memory = due(link, SendMemory(), 0.0)
    actions, memory = due(link, memory, 3.0)  # the daemon stalled for 3 s
    assert kinds(actions).count(Carrot) == 1 and memory.next_carrot_s == pytest.approx(3.0 + CARROT_PERIOD)


def test_nothing_without_a_command_or_a_recent_heartbeat() -> None:
    link = flying()
    link.command = None
    assert due(link, SendMemory(), 0.0)[0] == []
    link = flying()
    assert due(link, SendMemory(), 5.0)[0] != [] and due(link, SendMemory(), 5.01)[0] == []
    link.last_heartbeat_s = None
    assert due(link, SendMemory(), 0.0)[0] == []


def test_stream_rates_are_asked_when_the_link_is_up_and_again_only_while_one_falls_short() -> None:
    link = flying()
    link.command = None  # asked whether or not the vehicle is commanded
    actions, memory = due(link, SendMemory(), 0.0, stream_rate_hz=5.0)
    assert [(a.message_id, a.interval_us) for a in actions] == [(33, 200_000.0), (30, 200_000.0)]
    assert due(link, memory, 4.9, stream_rate_hz=5.0)[0] == []  # not checked before 5 s
    link.arrivals.update({"GLOBAL_POSITION_INT": 25, "ATTITUDE": 25})  # 5 Hz each over 5 s
    link.last_heartbeat_s = 5.0
    actions, memory = due(link, memory, 5.0, stream_rate_hz=5.0)
    assert actions == [] and memory.stream_rates_hz == pytest.approx((5.0, 5.0))
    link.arrivals.update({"GLOBAL_POSITION_INT": 5, "ATTITUDE": 25})  # position at 1 Hz over the next 5 s
    link.last_heartbeat_s = 10.0
    actions, memory = due(link, memory, 10.0, stream_rate_hz=5.0)
    assert kinds(actions) == [MessageInterval, MessageInterval] and memory.stream_rates_hz == pytest.approx((1.0, 5.0))
    assert due(link, memory.forget_streams(), 10.0, stream_rate_hz=5.0)[0] == actions  # a link back: asked at once


def test_stream_request_message_fields() -> None:
    sent = roundtrip(MessageInterval(33, 200_000.0).encode(mavlink.MAVLink(None, srcSystem=GCS_SYSID), 2),
                     sysid=GCS_SYSID)
    assert (sent.get_type(), sent.command, sent.target_system, sent.param1, sent.param2) == (
        "COMMAND_LONG", 511, 2, 33.0, 200_000.0)


def test_the_takeover_guard_waits_for_an_armed_vehicle_above_the_takeover_altitude() -> None:
    guard = Takeover(min_altitude_m=150.0)
    link = flying(mode=LOITER)
    link.armed = False

    def requests(memory: SendMemory, now: float) -> tuple[list, SendMemory]:
        actions, memory = due_actions(FRAME, link, memory, now, max_turn_rate_rad_s=TURN_RATE,
                                      carrot_period_s=CARROT_PERIOD, link_timeout_s=5.0, stream_rate_hz=0.0,
                                      takeover=guard)
        return [a for a in actions if isinstance(a, ModeRequest)], memory

    sent, memory = requests(SendMemory(), 0.0)
    assert sent == [] and memory.blocked == "disarmed"
    link.armed, link.position_enu_m = True, np.array([1200.0, 1300.0, 120.0])
    sent, memory = requests(memory, 1.0)
    assert sent == [] and memory.blocked == "below 150 m"
    link.position_enu_m = np.array([1200.0, 1300.0, 150.0])
    sent, memory = requests(memory, 2.0)
    assert sent == [ModeRequest(GUIDED)] and memory.blocked is None and not memory.took_over
    link.custom_mode = GUIDED
    _, memory = requests(memory, 3.0)
    assert memory.took_over


@pytest.mark.parametrize(("autopilot", "mode", "handback", "expected"), [
    (ARDUPILOT, GUIDED, "LOITER", ModeRequest(12)),
    (ARDUPILOT, GUIDED, "RTL", ModeRequest(11)),
    (PX4, OFFBOARD, "LOITER", ModeRequest(4, 3)),  # AUTO.LOITER
    (PX4, OFFBOARD, "RTL", ModeRequest(4, 5)),  # AUTO.RTL
])
def test_a_vehicle_let_go_of_is_given_back_once_in_the_handback_mode(autopilot: int, mode: int, handback: str,
                                                                      expected: ModeRequest) -> None:
    link = flying(autopilot=autopilot, mode=mode)
    guard = Takeover(handback=handback)
    kwargs = dict(max_turn_rate_rad_s=TURN_RATE, carrot_period_s=CARROT_PERIOD, link_timeout_s=5.0,
                  stream_rate_hz=0.0, takeover=guard)
    _, memory = due_actions(FRAME, link, SendMemory(), 0.0, **kwargs)
    assert memory.took_over
    link.command = None
    actions, memory = due_actions(FRAME, link, memory.let_go(), 0.5, **kwargs)
    assert actions == [expected]
    assert due_actions(FRAME, link, memory, 1.5, **kwargs)[0] == []  # once
    never = flying(autopilot=autopilot, mode=LOITER)  # never taken over: nothing to give back
    never.command = None
    assert due_actions(FRAME, never, SendMemory().let_go(), 0.0, **kwargs)[0] == []


def test_handback_request_fields_for_px4() -> None:
    sent = roundtrip(ModeRequest(4, 5).encode(mavlink.MAVLink(None, srcSystem=GCS_SYSID), 3), sysid=GCS_SYSID)
    assert (sent.command, sent.param1, sent.param2, sent.param3) == (176, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                                                     4.0, 5.0)


def test_invalid_commands_and_rosters_are_refused_before_any_socket_opens() -> None:
    with pytest.raises(ValueError, match="airspeed"):
        HeadingCommand(0.0, 200.0, 0.0)
    with pytest.raises(ValueError, match="finite"):
        HeadingCommand(math.nan, 200.0, 25.0)
    with pytest.raises(ValueError, match="one connection"):
        MavlinkCommander(FRAME, {"uav1": 1, "uav2": 2}, {"uav1": "udpin:127.0.0.1:14550"})
    with pytest.raises(ValueError, match="distinct"):
        MavlinkCommander(FRAME, {"uav1": 1, "uav2": 1}, dict.fromkeys(("uav1", "uav2"), "udpin:127.0.0.1:14550"))
    with pytest.raises(ValueError, match="32 bytes"):
        MavlinkCommander(FRAME, {"uav1": 1}, {"uav1": "udpin:127.0.0.1:14550"}, signing_key=b"short")
