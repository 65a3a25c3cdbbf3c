"""The MAVLink face of one simulated fixed-wing: an ArduPlane-like command set and telemetry.

:class:`SimAutopilot` holds what a flight controller holds (mode, arming, the
active guidance, home) and speaks the send/accept set of reference/mavlink.md:

* **Accepts** ``MAV_CMD_DO_SET_MODE`` and legacy ``SET_MODE``;
  ``MAV_CMD_COMPONENT_ARM_DISARM``; ``SET_POSITION_TARGET_GLOBAL_INT`` in GUIDED
  only (position carrot -> fly toward it; else velocity -> its bearing; else
  yaw), dropped silently in other modes as ArduPlane does;
  ``COMMAND_INT MAV_CMD_DO_REPOSITION`` (switches to GUIDED when param2 has
  ``MAV_DO_REPOSITION_FLAGS_CHANGE_MODE``), and the guided-goto
  ``MISSION_ITEM_INT`` (current = 2) older MAVProxy versions send;
  ``MAV_CMD_GUIDED_CHANGE_HEADING`` / ``_SPEED`` / ``_ALTITUDE`` (GUIDED only);
  ``MAV_CMD_DO_CHANGE_SPEED``; message requests (``MAV_CMD_REQUEST_MESSAGE``,
  ``REQUEST_AUTOPILOT_CAPABILITIES``, ``GET_HOME_POSITION``);
  ``SET_MESSAGE_INTERVAL`` (acknowledged); ``PARAM_REQUEST_LIST`` /
  ``_READ`` / ``PARAM_SET`` over a small parameter set; ``MISSION_REQUEST_LIST``
  (no mission: ``MISSION_COUNT`` 0). Every command gets a ``COMMAND_ACK``.
* **Ignores** messages addressed to another system and GCS heartbeats (it
  records when it last heard one).
* **Sends** HEARTBEAT (fixed-wing, ArduPilot, so tools use ArduPlane's mode
  numbers), SYS_STATUS, GLOBAL_POSITION_INT, ATTITUDE, GPS_RAW_INT, VFR_HUD and,
  in GUIDED with a target, POSITION_TARGET_GLOBAL_INT.

Modes: GUIDED (15) follows commands; LOITER (12) and CIRCLE (1) circle where
the mode was entered; RTL (11) and AUTO (10, no mission) circle home; MANUAL,
STABILIZE, FBWA, FBWB, CRUISE, TRAINING and ACRO hold the current heading
(no pilot on the sticks). Entering GUIDED loiters at the current position until
a command arrives, as ArduPlane does. The vehicle is airborne and armed from
the start; a disarm request in flight is refused, as ArduPlane refuses it
without the force code.

Altitudes in commands: frames GLOBAL (0) and GLOBAL_INT (5) are above mean sea
level; GLOBAL_RELATIVE_ALT (3, 6) relative to home; terrain frames (10, 11) are
taken as relative to home (the simulated ground is flat at the origin's height).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np

from gcs.adapters.mavlink_wire import ARDUPLANE_MODE_NAMES, ARDUPLANE_MODES, mavlink, ned_yaw_from_enu_heading
from gcs.config import AirframeConfig
from gcs.core.geometry import LocalFrame
from sim_vehicles.truth.fixed_wing import AirframeState, Guidance
from sim_vehicles.truth.gps import GpsReading

__all__ = ["SimAutopilot", "HEADING_HOLD_MODES", "LOITER_MODES", "HOME_MODES"]

log = logging.getLogger(__name__)

GUIDED = ARDUPLANE_MODES["GUIDED"]
LOITER_MODES = frozenset({ARDUPLANE_MODES["LOITER"], ARDUPLANE_MODES["CIRCLE"]})
HOME_MODES = frozenset({ARDUPLANE_MODES["RTL"], ARDUPLANE_MODES["AUTO"]})
HEADING_HOLD_MODES = frozenset(ARDUPLANE_MODES[name] for name in
                               ("MANUAL", "STABILIZE", "FBWA", "FBWB", "CRUISE", "TRAINING", "ACRO"))
SUPPORTED_MODES = frozenset({GUIDED}) | LOITER_MODES | HOME_MODES | HEADING_HOLD_MODES

_RELATIVE_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                              mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_MSL_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT})

_MASK_X, _MASK_Y, _MASK_Z = 1, 2, 4
_MASK_VX, _MASK_VY = 8, 16
_MASK_YAW = 1024

_SENSORS = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
            | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
            | mavlink.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE | mavlink.MAV_SYS_STATUS_SENSOR_GPS
            | mavlink.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
            | mavlink.MAV_SYS_STATUS_SENSOR_YAW_POSITION | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
            | mavlink.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS)

_CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                 | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                 | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT)

SOFTWARE_VERSION = (0, 1, 0)
"""Reported in AUTOPILOT_VERSION.flight_sw_version (major, minor, patch), FIRMWARE_VERSION_TYPE_DEV."""


@dataclass
class SimAutopilot:
    """Mode, arming and guidance of one vehicle, driven by MAVLink messages.

    Parameters
    ----------
    sysid : int
        This vehicle's MAVLink system id (component 1).
    frame : LocalFrame
        The scenario's ENU frame; its origin is home (at ground level).
    airframe : AirframeConfig
        For the default loiter radius.
    cruise_airspeed_mps, cruise_altitude_m : float
        Initial commands (the scenario's speed and altitude).
    encoder : mavlink.MAVLink
        Builds the outgoing messages (``*_encode``); never sends.
    """

    sysid: int
    frame: LocalFrame
    airframe: AirframeConfig
    cruise_airspeed_mps: float
    cruise_altitude_m: float
    encoder: mavlink.MAVLink
    mode: int = ARDUPLANE_MODES["LOITER"]
    armed: bool = True
    guidance: Guidance | None = None
    guided_target_enu_m: tuple[float, float, float] | None = None
    last_gcs_heartbeat_s: float | None = None
    counters: Counter = field(default_factory=Counter)
    params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.params = {
            "SYSID_THISMAV": float(self.sysid),
            "AIRSPEED_CRUISE": float(self.cruise_airspeed_mps),
            "WP_LOITER_RAD": float(self.airframe.loiter_radius_m),
            "ROLL_LIMIT_DEG": math.degrees(self.airframe.max_bank_rad),
            "AIRSPEED_MIN": float(self.airframe.min_airspeed_mps),
            "AIRSPEED_MAX": float(self.airframe.max_airspeed_mps),
        }

    # ----------------------------------------------------------------- guidance

    @property
    def mode_name(self) -> str:
        """ArduPlane name of the current mode."""
        return ARDUPLANE_MODE_NAMES.get(self.mode, str(self.mode))

    def start(self, state: AirframeState) -> None:
        """Begin in the initial mode (LOITER about the start point)."""
        self._enter_mode(self.mode, state)

    def _hold(self, kind: str, state: AirframeState, **changes) -> Guidance:
        base = self.guidance or Guidance(kind="loiter", altitude_m=self.cruise_altitude_m,
                                         airspeed_mps=self.cruise_airspeed_mps, radius_m=self.airframe.loiter_radius_m)
        return replace(base, kind=kind, max_turn_rate_rad_s=None, **changes)

    def _loiter_here(self, state: AirframeState) -> Guidance:
        point = (float(state.position_enu_m[0]), float(state.position_enu_m[1]))
        return self._hold("loiter", state, point_enu_m=point, radius_m=self.airframe.loiter_radius_m, clockwise=True)

    def _enter_mode(self, mode: int, state: AirframeState) -> None:
        self.mode = mode
        self.guided_target_enu_m = None
        if mode == GUIDED or mode in LOITER_MODES:
            self.guidance = self._loiter_here(state)
        elif mode in HOME_MODES:
            self.guidance = self._hold("loiter", state, point_enu_m=(0.0, 0.0), radius_m=self.airframe.loiter_radius_m,
                                       clockwise=True)
        else:
            self.guidance = self._hold("heading", state, direction_rad=state.heading_rad)

    def _set_mode(self, mode: int, state: AirframeState) -> int:
        if mode not in SUPPORTED_MODES:
            return mavlink.MAV_RESULT_FAILED
        if mode != self.mode:
            log.info("vehicle %d: mode %s -> %s", self.sysid, self.mode_name, ARDUPLANE_MODE_NAMES.get(mode, mode))
            self._enter_mode(mode, state)
        return mavlink.MAV_RESULT_ACCEPTED

    def _altitude_from(self, frame: int, z: float) -> float | None:
        """Commanded ENU altitude from a MAVLink frame and z, or None when the frame is not global."""
        if not math.isfinite(z):
            return self.guidance.altitude_m if self.guidance else self.cruise_altitude_m
        if frame in _RELATIVE_FRAMES:
            return float(z)
        if frame in _MSL_FRAMES:
            return float(z) - self.frame.height_m
        return None

    def _enu(self, lat_e7: int, lon_e7: int, altitude_m: float) -> tuple[float, float, float]:
        enu = self.frame.to_enu(lat_e7 * 1e-7, lon_e7 * 1e-7, self.frame.height_m + altitude_m)
        return float(enu[0]), float(enu[1]), float(altitude_m)

    def _goto(self, state: AirframeState, lat_e7: int, lon_e7: int, altitude_m: float,
              radius_m: float | None = None, clockwise: bool = True) -> None:
        x, y, z = self._enu(lat_e7, lon_e7, altitude_m)
        self.guided_target_enu_m = (x, y, z)
        radius = radius_m if radius_m and radius_m > 0 else self.airframe.loiter_radius_m
        self.guidance = self._hold("goto", state, point_enu_m=(x, y), altitude_m=z, radius_m=radius, clockwise=clockwise)

    # ------------------------------------------------------------------ ingress

    def handle(self, msg, now_s: float, state: AirframeState) -> list:
        """Apply one received message; returns the replies to send (possibly none)."""
        kind = msg.get_type()
        target = getattr(msg, "target_system", None)
        if target is not None and target not in (0, self.sysid):
            return []
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS:
                self.last_gcs_heartbeat_s = now_s
            return []
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is None:
            self.counters["ignored"] += 1
            return []
        self.counters[kind] += 1
        return handler(msg, now_s, state)

    def _ack(self, msg, command: int, result: int) -> list:
        if result != mavlink.MAV_RESULT_ACCEPTED:
            log.info("vehicle %d: command %d -> result %d", self.sysid, command, result)
        return [self.encoder.command_ack_encode(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())]

    def _on_command_long(self, msg, now_s: float, state: AirframeState) -> list:
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        return self._command(msg, msg.command, params, None, state, now_s)

    def _on_command_int(self, msg, now_s: float, state: AirframeState) -> list:
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z)
        return self._command(msg, msg.command, params, msg.frame, state, now_s)

    def _command(self, msg, command: int, p: tuple, frame: int | None, state: AirframeState, now_s: float) -> list:
        """Execute a COMMAND_LONG (frame None) or COMMAND_INT; the ACK comes first in the replies."""
        extra: list = []
        if command == mavlink.MAV_CMD_DO_SET_MODE:
            if not int(p[0]) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                result = mavlink.MAV_RESULT_UNSUPPORTED
            else:
                result = self._set_mode(int(p[1]), state)
        elif command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            result = mavlink.MAV_RESULT_ACCEPTED if p[0] == 1 else mavlink.MAV_RESULT_DENIED  # airborne: no disarm
        elif command == mavlink.MAV_CMD_DO_REPOSITION:
            result = self._reposition(p, frame, state)
        elif command == mavlink.MAV_CMD_GUIDED_CHANGE_HEADING:
            result = self._change_heading(p, state)
        elif command == mavlink.MAV_CMD_GUIDED_CHANGE_SPEED:
            result = self._change_guided(state, airspeed_mps=float(p[1])) if p[1] > 0 else mavlink.MAV_RESULT_DENIED
        elif command == mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE:
            altitude = self._altitude_from(frame if frame is not None else mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, p[6])
            result = mavlink.MAV_RESULT_DENIED if altitude is None else self._change_guided(state, altitude_m=altitude)
        elif command == mavlink.MAV_CMD_DO_CHANGE_SPEED:
            result = self._change_speed(float(p[1]))
        elif command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            reply = self._message(int(p[0]), now_s, state)
            result = mavlink.MAV_RESULT_ACCEPTED if reply is not None else mavlink.MAV_RESULT_UNSUPPORTED
            extra = [reply] if reply is not None else []
        elif command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            result, extra = mavlink.MAV_RESULT_ACCEPTED, [self.autopilot_version()]
        elif command == mavlink.MAV_CMD_GET_HOME_POSITION:
            result, extra = mavlink.MAV_RESULT_ACCEPTED, [self.home_position(now_s)]
        elif command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = mavlink.MAV_RESULT_ACCEPTED
        else:
            result = mavlink.MAV_RESULT_UNSUPPORTED
        return self._ack(msg, command, result) + extra

    def _reposition(self, p: tuple, frame: int | None, state: AirframeState) -> int:
        if frame is None:
            return mavlink.MAV_RESULT_UNSUPPORTED  # ArduPlane: COMMAND_INT only
        altitude = self._altitude_from(frame, p[6])
        if altitude is None:
            return mavlink.MAV_RESULT_FAILED
        if self.mode != GUIDED:
            if not int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE:
                return mavlink.MAV_RESULT_FAILED
            self._set_mode(GUIDED, state)
        if p[0] > 0:  # ground speed, -1 for default
            self.cruise_airspeed_mps = float(p[0])
            self._change_guided(state, airspeed_mps=float(p[0]))
        self._goto(state, int(p[4]), int(p[5]), altitude, radius_m=abs(float(p[2])), clockwise=p[3] != 1)
        return mavlink.MAV_RESULT_ACCEPTED

    def _change_heading(self, p: tuple, state: AirframeState) -> int:
        if self.mode != GUIDED:
            return mavlink.MAV_RESULT_FAILED
        if not 0.0 <= p[1] < 360.0 or int(p[0]) not in (0, 1):
            return mavlink.MAV_RESULT_DENIED
        direction = ned_yaw_from_enu_heading(math.radians(p[1]))
        limit = float(p[2]) / max(state.airspeed_mps, 1.0) if p[2] > 0 else None
        self.guided_target_enu_m = None
        self.guidance = replace(self._hold("heading" if int(p[0]) == 1 else "course", state, direction_rad=direction),
                                max_turn_rate_rad_s=limit)
        return mavlink.MAV_RESULT_ACCEPTED

    def _change_guided(self, state: AirframeState, **changes) -> int:
        if self.mode != GUIDED or self.guidance is None:
            return mavlink.MAV_RESULT_FAILED
        self.guidance = replace(self.guidance, **changes)
        return mavlink.MAV_RESULT_ACCEPTED

    def _change_speed(self, speed_mps: float) -> int:
        if not speed_mps > 0:
            return mavlink.MAV_RESULT_DENIED
        self.cruise_airspeed_mps = speed_mps
        if self.guidance is not None:
            self.guidance = replace(self.guidance, airspeed_mps=speed_mps)
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_mode(self, msg, now_s: float, state: AirframeState) -> list:
        if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self._set_mode(int(msg.custom_mode), state)
        return []

    def _on_set_position_target_global_int(self, msg, now_s: float, state: AirframeState) -> list:
        if self.mode != GUIDED:
            self.counters["position_target_outside_guided"] += 1
            return []  # ArduPlane drops it silently outside GUIDED
        mask = msg.type_mask
        altitude = None if mask & _MASK_Z else self._altitude_from(msg.coordinate_frame, msg.alt)
        if not mask & _MASK_Z and altitude is None:
            self.counters["position_target_bad_frame"] += 1
            return []
        altitude = altitude if altitude is not None else self.guidance.altitude_m
        if not mask & (_MASK_X | _MASK_Y):
            self._goto(state, msg.lat_int, msg.lon_int, altitude, radius_m=self.guidance.radius_m)
        elif not mask & (_MASK_VX | _MASK_VY) and math.hypot(msg.vx, msg.vy) > 0:
            course = math.atan2(msg.vx, msg.vy)  # NED (north, east) velocity -> ENU course
            self.guided_target_enu_m = None
            self.guidance = self._hold("course", state, direction_rad=course, altitude_m=altitude)
        elif not mask & _MASK_YAW:
            self.guided_target_enu_m = None
            self.guidance = self._hold("heading", state, direction_rad=ned_yaw_from_enu_heading(msg.yaw),
                                       altitude_m=altitude)
        else:
            self.guidance = replace(self.guidance, altitude_m=altitude)
        return []

    def _on_mission_item_int(self, msg, now_s: float, state: AirframeState) -> list:
        if msg.current != 2:  # only the guided "fly to" form; we keep no missions
            return [self.encoder.mission_ack_encode(msg.get_srcSystem(), msg.get_srcComponent(),
                                                    mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)]
        altitude = self._altitude_from(msg.frame, msg.z)
        if self.mode != GUIDED or altitude is None:
            result = mavlink.MAV_MISSION_ERROR
        else:
            self._goto(state, msg.x, msg.y, altitude)
            result = mavlink.MAV_MISSION_ACCEPTED
        return [self.encoder.mission_ack_encode(msg.get_srcSystem(), msg.get_srcComponent(), result, msg.mission_type)]

    def _on_mission_request_list(self, msg, now_s: float, state: AirframeState) -> list:
        return [self.encoder.mission_count_encode(msg.get_srcSystem(), msg.get_srcComponent(), 0, msg.mission_type)]

    def _param_value(self, name: str) -> object:
        names = list(self.params)
        return self.encoder.param_value_encode(name.encode("ascii"), self.params[name],
                                               mavlink.MAV_PARAM_TYPE_REAL32, len(names), names.index(name))

    def _on_param_request_list(self, msg, now_s: float, state: AirframeState) -> list:
        return [self._param_value(name) for name in self.params]

    def _on_param_request_read(self, msg, now_s: float, state: AirframeState) -> list:
        names = list(self.params)
        name = _param_name(msg.param_id)
        if msg.param_index >= 0:
            name = names[msg.param_index] if msg.param_index < len(names) else ""
        return [self._param_value(name)] if name in self.params else []

    def _on_param_set(self, msg, now_s: float, state: AirframeState) -> list:
        name = _param_name(msg.param_id)
        if name not in self.params or not math.isfinite(msg.param_value) or name == "SYSID_THISMAV":
            return [self._param_value(name)] if name in self.params else []
        self.params[name] = float(msg.param_value)
        if name == "AIRSPEED_CRUISE":
            self._change_speed(float(msg.param_value))
        return [self._param_value(name)]

    # ------------------------------------------------------------------ egress

    def _message(self, message_id: int, now_s: float, state: AirframeState):
        if message_id == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return self.autopilot_version()
        if message_id == mavlink.MAVLINK_MSG_ID_HOME_POSITION:
            return self.home_position(now_s)
        if message_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            return self.heartbeat()
        return None

    def heartbeat(self):
        """HEARTBEAT: fixed-wing, ArduPilot, custom mode, armed flag, ACTIVE in flight."""
        base = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0))
        status = mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY
        return self.encoder.heartbeat_encode(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                             base, self.mode, status)

    def sys_status(self):
        """SYS_STATUS with every simulated sensor present, enabled and healthy."""
        return self.encoder.sys_status_encode(_SENSORS, _SENSORS, _SENSORS, 100, 12600, -1, -1, 0, 0, 0, 0, 0, 0)

    def autopilot_version(self):
        """AUTOPILOT_VERSION: capabilities and this simulator's version."""
        major, minor, patch = SOFTWARE_VERSION
        version = (major << 24) | (minor << 16) | (patch << 8) | mavlink.FIRMWARE_VERSION_TYPE_DEV
        return self.encoder.autopilot_version_encode(_CAPABILITIES, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
                                                     0, 0, self.sysid)

    def home_position(self, now_s: float):
        """HOME_POSITION: the scenario origin at ground level."""
        lat_e7, lon_e7 = _e7(self.frame.lat_deg), _e7(self.frame.lon_deg)
        return self.encoder.home_position_encode(lat_e7, lon_e7, int(round(self.frame.height_m * 1000)),
                                                 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0,
                                                 int(now_s * 1e6))

    def telemetry(self, now_s: float, state: AirframeState, gps: GpsReading, wind_enu_mps: tuple[float, float]) -> list:
        """The position/attitude stream: GLOBAL_POSITION_INT, ATTITUDE, GPS_RAW_INT, VFR_HUD (+ target echo)."""
        boot_ms = int(now_s * 1000) & 0xFFFFFFFF
        lat, lon, _ = self.frame.to_geodetic(state.position_enu_m)
        altitude = float(state.position_enu_m[2])
        msl_mm = int(round((self.frame.height_m + altitude) * 1000))
        velocity = state.ground_velocity(wind_enu_mps)  # ENU
        yaw = ned_yaw_from_enu_heading(state.heading_rad)
        hdg_cdeg = int(round(math.degrees(yaw) * 100)) % 36000
        ground_speed = math.hypot(velocity[0], velocity[1])
        course_cdeg = int(round(math.degrees(ned_yaw_from_enu_heading(state.course_rad(wind_enu_mps))) * 100)) % 36000
        messages = [
            self.encoder.global_position_int_encode(
                boot_ms, _e7(lat), _e7(lon), msl_mm, int(round(altitude * 1000)),
                _cm(velocity[1]), _cm(velocity[0]), _cm(-velocity[2]), hdg_cdeg),
            self.encoder.attitude_encode(
                boot_ms, state.roll_rad, math.atan2(state.climb_rate_mps, state.airspeed_mps), yaw,
                0.0, 0.0, -state.turn_rate_rad_s),
            self._gps_raw(now_s, gps, ground_speed, course_cdeg),
            self.encoder.vfr_hud_encode(
                state.airspeed_mps, ground_speed, hdg_cdeg // 100, 50, self.frame.height_m + altitude,
                state.climb_rate_mps),
        ]
        if self.mode == GUIDED and self.guided_target_enu_m is not None:
            x, y, z = self.guided_target_enu_m
            t_lat, t_lon, _ = self.frame.to_geodetic(np.array([x, y, z]))
            messages.append(self.encoder.position_target_global_int_encode(
                boot_ms, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0x0DF8, _e7(t_lat), _e7(t_lon), z,
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        return messages

    def _gps_raw(self, now_s: float, gps: GpsReading, ground_speed: float, course_cdeg: int):
        usec = int(now_s * 1e6)
        if gps.position_enu_m is None:
            return self.encoder.gps_raw_int_encode(usec, gps.fix_type, 0, 0, 0, 65535, 65535, 65535, 65535, 0,
                                                   0, 0, 0, 0, 0)
        lat, lon, _ = self.frame.to_geodetic(gps.position_enu_m)
        msl_mm = int(round((self.frame.height_m + float(gps.position_enu_m[2])) * 1000))
        return self.encoder.gps_raw_int_encode(
            usec, gps.fix_type, _e7(lat), _e7(lon), msl_mm, 121, 200, _cm(ground_speed), course_cdeg,
            gps.satellites, msl_mm, int(gps.horizontal_std_m * 1000), int(gps.vertical_std_m * 1000), 0, 0)


def _e7(degrees) -> int:
    return int(round(float(degrees) * 1e7))


def _cm(metres_per_s: float) -> int:
    return int(max(min(round(metres_per_s * 100.0), 32767), -32768))


def _param_name(raw) -> str:
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else str(raw)
    return text.rstrip("\x00")
