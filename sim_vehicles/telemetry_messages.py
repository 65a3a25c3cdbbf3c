"""The messages a simulated vehicle sends about itself, built from its truth state (no sending here).

Units at this edge follow docs/mavlink.md: lat/lon as 1e7 integers, altitude
in mm (MSL and relative to home), velocities in cm/s NED, yaw NED from north; the
vehicle's state is ENU inside. :func:`stream_message` builds one streamed message
by id (:data:`sim_vehicles.streams.STREAMED_MESSAGES`).
"""

from __future__ import annotations

import math
import struct

import numpy as np

from gcs.adapters.mavlink_wire import mavlink, ned_yaw_from_enu_heading
from gcs.core.geometry import LocalFrame
from sim_vehicles.truth.fixed_wing import AirframeState
from sim_vehicles.truth.gps import GpsReading

__all__ = ["SENSORS", "HEALTHY", "CAPABILITIES", "SOFTWARE_VERSION", "autopilot_version", "home_position",
           "stream_message", "sys_status", "ftp_refusal", "e7", "param_name"]

SENSORS = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
           | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
           | mavlink.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE | mavlink.MAV_SYS_STATUS_SENSOR_GPS
           | mavlink.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
           | mavlink.MAV_SYS_STATUS_SENSOR_YAW_POSITION | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
           | mavlink.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
           | mavlink.MAV_SYS_STATUS_AHRS)
"""The sensors and controllers a simulated vehicle has: present, enabled and healthy (SYS_STATUS)."""
HEALTHY = SENSORS | mavlink.MAV_SYS_STATUS_GEOFENCE
"""SYS_STATUS health: every sensor, and the geofence bit of a fence not breached. ArduPilot sets that bit
whether or not a fence is present ("GEOFENCE always defaults to healthy"), and ground stations read a clear
bit as a breach: MAVProxy's fence module announces "fence breach" when it sees the bit clear."""

CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT)

SOFTWARE_VERSION = (0, 1, 0)
"""Reported in AUTOPILOT_VERSION.flight_sw_version (major, minor, patch), FIRMWARE_VERSION_TYPE_DEV."""


def e7(degrees) -> int:
    """Degrees as a 1e7-scaled integer."""
    return int(round(float(degrees) * 1e7))


def _cm(metres_per_s: float) -> int:
    return int(max(min(round(metres_per_s * 100.0), 32767), -32768))


def param_name(raw) -> str:
    """A PARAM_* id field as text, without its NUL padding."""
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.rstrip("\x00")


def sys_status(encoder: mavlink.MAVLink):
    """SYS_STATUS with every simulated sensor present, enabled and healthy, and no fence breached."""
    return encoder.sys_status_encode(SENSORS, SENSORS, HEALTHY, 100, 12600, -1, -1, 0, 0, 0, 0, 0, 0)


FTP_NAK = 129
"""MAVLink FTP's NAK opcode (``Nack``); 128 is its ACK."""
FTP_UNKNOWN_COMMAND = 7
"""MAVLink FTP's error ``UnknownCommand``: the server does not carry out this request."""
_FTP_HEADER = struct.Struct("<HBBBBBBI")  # seq, session, opcode, size, req_opcode, burst_complete, padding, offset


def ftp_refusal(encoder: mavlink.MAVLink, request):
    """The NAK (``UnknownCommand``) that answers a FILE_TRANSFER_PROTOCOL request, or None for an ACK or NAK.

    The simulated vehicle keeps no files and its AUTOPILOT_VERSION does not claim
    MAV_PROTOCOL_CAPABILITY_FTP. A ground station may try FTP all the same (MAVProxy fetches the
    parameters as ``@PARAM/param.pck`` first): refused at once, it falls back to PARAM_REQUEST_LIST
    without waiting for its FTP time-out. The reply carries the request's sequence number plus one,
    its session and its opcode, as an FTP server's replies do."""
    payload = bytes(request.payload)
    if len(payload) < _FTP_HEADER.size:
        return None
    seq, session, opcode = _FTP_HEADER.unpack_from(payload)[:3]
    if opcode >= 128:  # a reply (ACK or NAK), not a request
        return None
    reply = _FTP_HEADER.pack((seq + 1) & 0xFFFF, session, FTP_NAK, 1, opcode, 0, 0, 0) + bytes([FTP_UNKNOWN_COMMAND])
    return encoder.file_transfer_protocol_encode(0, request.get_srcSystem(), request.get_srcComponent(),
                                                 list(reply.ljust(251, b"\0")))


def autopilot_version(encoder: mavlink.MAVLink, sysid: int):
    """AUTOPILOT_VERSION: capabilities and this simulator's version."""
    major, minor, patch = SOFTWARE_VERSION
    version = (major << 24) | (minor << 16) | (patch << 8) | mavlink.FIRMWARE_VERSION_TYPE_DEV
    return encoder.autopilot_version_encode(CAPABILITIES, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, sysid)


def home_position(encoder: mavlink.MAVLink, frame: LocalFrame, now_s: float):
    """HOME_POSITION: the scenario origin at ground level."""
    return encoder.home_position_encode(e7(frame.lat_deg), e7(frame.lon_deg), int(round(frame.height_m * 1000)),
                                        0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, int(now_s * 1e6))


def stream_message(encoder: mavlink.MAVLink, frame: LocalFrame, message_id: int, now_s: float, state: AirframeState,
                   gps: GpsReading, wind_enu_mps: tuple[float, float],
                   target_enu_m: tuple[float, float, float] | None):
    """One streamed message (GLOBAL_POSITION_INT, ATTITUDE, GPS_RAW_INT, VFR_HUD or POSITION_TARGET_GLOBAL_INT),
    or None when there is nothing to say (no target to echo)."""
    boot_ms = int(now_s * 1000) & 0xFFFFFFFF
    altitude = float(state.position_enu_m[2])
    velocity = state.ground_velocity(wind_enu_mps)  # ENU
    yaw = ned_yaw_from_enu_heading(state.heading_rad)
    hdg_cdeg = int(round(math.degrees(yaw) * 100)) % 36000
    ground_speed = math.hypot(velocity[0], velocity[1])
    if message_id == mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
        lat, lon, _ = frame.to_geodetic(state.position_enu_m)
        return encoder.global_position_int_encode(
            boot_ms, e7(lat), e7(lon), int(round((frame.height_m + altitude) * 1000)), int(round(altitude * 1000)),
            _cm(velocity[1]), _cm(velocity[0]), _cm(-velocity[2]), hdg_cdeg)
    if message_id == mavlink.MAVLINK_MSG_ID_ATTITUDE:
        return encoder.attitude_encode(boot_ms, state.roll_rad, math.atan2(state.climb_rate_mps, state.airspeed_mps),
                                       yaw, 0.0, 0.0, -state.turn_rate_rad_s)
    if message_id == mavlink.MAVLINK_MSG_ID_GPS_RAW_INT:
        course = ned_yaw_from_enu_heading(state.course_rad(wind_enu_mps))
        return _gps_raw(encoder, frame, now_s, gps, ground_speed, int(round(math.degrees(course) * 100)) % 36000)
    if message_id == mavlink.MAVLINK_MSG_ID_VFR_HUD:
        return encoder.vfr_hud_encode(state.airspeed_mps, ground_speed, hdg_cdeg // 100, 50, frame.height_m + altitude,
                                      state.climb_rate_mps)
    if message_id == mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT and target_enu_m is not None:
        x, y, z = target_enu_m
        t_lat, t_lon, _ = frame.to_geodetic(np.array([x, y, z]))
        return encoder.position_target_global_int_encode(
            boot_ms, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0x0DF8, e7(t_lat), e7(t_lon), z,
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    return None


def _gps_raw(encoder: mavlink.MAVLink, frame: LocalFrame, now_s: float, gps: GpsReading, ground_speed: float,
             course_cdeg: int):
    usec = int(now_s * 1e6)
    if gps.position_enu_m is None:
        return encoder.gps_raw_int_encode(usec, gps.fix_type, 0, 0, 0, 65535, 65535, 65535, 65535, 0, 0, 0, 0, 0, 0)
    lat, lon, _ = frame.to_geodetic(gps.position_enu_m)
    msl_mm = int(round((frame.height_m + float(gps.position_enu_m[2])) * 1000))
    return encoder.gps_raw_int_encode(
        usec, gps.fix_type, e7(lat), e7(lon), msl_mm, 121, 200, _cm(ground_speed), course_cdeg,
        gps.satellites, msl_mm, int(gps.horizontal_std_m * 1000), int(gps.vertical_std_m * 1000), 0, 0)
