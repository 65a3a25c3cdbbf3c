"""The ``ideal`` autopilot personality: an ArduPlane-like command set that obeys every steering message.

:class:`SimAutopilot` holds what a flight controller holds (mode, arming, the
active guidance, home, stream rates) and speaks the send/accept set of
docs/mavlink.md. It is also the base of the personalities that behave as
the real autopilots do (:mod:`sim_vehicles.arduplane`, :mod:`sim_vehicles.px4`),
which override the hooks named below.

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
  ``SET_MESSAGE_INTERVAL`` and ``REQUEST_DATA_STREAM`` with ArduPilot's
  semantics (:mod:`sim_vehicles.streams`; every stream starts at the scenario's
  ``telemetry_rate_hz``); ``PARAM_REQUEST_LIST`` /
  ``_READ`` / ``PARAM_SET`` over a small parameter set; ``MISSION_REQUEST_LIST``
  (no mission: ``MISSION_COUNT`` 0). Every command gets a ``COMMAND_ACK``.
* **Refuses** MAVLink FTP (``FILE_TRANSFER_PROTOCOL``): a NAK for every request, so that a ground
  station fetches the parameters with ``PARAM_REQUEST_LIST`` at once instead of after an FTP time-out.
* **Ignores** messages addressed to another system and GCS heartbeats (noting the time).
* **Sends** HEARTBEAT (fixed-wing, ArduPilot, so tools use ArduPlane's mode
  numbers), SYS_STATUS, GLOBAL_POSITION_INT, ATTITUDE, GPS_RAW_INT, VFR_HUD and,
  in GUIDED with a target, POSITION_TARGET_GLOBAL_INT.

Modes: GUIDED (15) follows commands; LOITER (12) and CIRCLE (1) circle where
the mode was entered; RTL (11) and AUTO (10, no mission) circle home; MANUAL,
STABILIZE, FBWA, FBWB, CRUISE, TRAINING and ACRO hold the current heading. Entering GUIDED loiters at the current position until
a command arrives, as ArduPlane does. The vehicle is airborne and armed from
the start; a disarm request in flight is refused.

**On the ground** (``[simulation] start_on_ground``): :mod:`sim_vehicles.ground`.

Altitudes in commands: frames GLOBAL (0) and GLOBAL_INT (5) are above mean sea
level; GLOBAL_RELATIVE_ALT (3, 6) relative to home; terrain frames (10, 11) are
taken as relative to home (the simulated ground is flat at the origin's height).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass, field, replace

from gcs.adapters.mavlink_wire import ARDUPLANE_MODE_NAMES, ARDUPLANE_MODES, mavlink, ned_yaw_from_enu_heading
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import LocalFrame
from sim_vehicles import telemetry_messages
from sim_vehicles.streams import STREAMED_MESSAGES, MessageSchedule
from sim_vehicles.autopilot_params import ParameterTable
from sim_vehicles.egress import Egress
from sim_vehicles.ground import GroundStart
from sim_vehicles.truth.fixed_wing import AirframeState, Guidance, GuidanceKind

__all__ = ["SimAutopilot", "HEADING_HOLD_MODES", "LOITER_MODES", "HOME_MODES"]

log = logging.getLogger(__name__)

GUIDED = ARDUPLANE_MODES["GUIDED"]
LOITER_MODES = frozenset({ARDUPLANE_MODES["LOITER"], ARDUPLANE_MODES["CIRCLE"]})
HOME_MODES = frozenset({ARDUPLANE_MODES["RTL"], ARDUPLANE_MODES["AUTO"]})
HEADING_HOLD_MODES = frozenset(ARDUPLANE_MODES[name] for name in
                               ("MANUAL", "STABILIZE", "FBWA", "FBWB", "CRUISE", "TRAINING", "ACRO"))
SUPPORTED_MODES = frozenset({GUIDED, ARDUPLANE_MODES["TAKEOFF"]}) | LOITER_MODES | HOME_MODES | HEADING_HOLD_MODES

_RELATIVE_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                              mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_MSL_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT})

_MASK_X, _MASK_Y, _MASK_Z = 1, 2, 4
_MASK_VX, _MASK_VY = 8, 16
_MASK_YAW = 1024

@dataclass
class SimAutopilot(GroundStart, Egress, ParameterTable):
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
    telemetry_rate_hz : float
        The rate every streamed message starts at (scenario ``[simulation]``), until a
        GCS asks for another one.
    """

    personality = "ideal"
    """The name a scenario gives this behaviour (``autopilot = "ideal"``)."""
    takeoff_mode = ARDUPLANE_MODES["TAKEOFF"]
    takeoff_altitude_param = "TKOFF_ALT"
    ground_mode = ARDUPLANE_MODES["MANUAL"]
    disarm_in_flight_result = mavlink.MAV_RESULT_DENIED

    sysid: int
    frame: LocalFrame
    airframe: AirframeConfig
    cruise_airspeed_mps: float
    cruise_altitude_m: float
    encoder: mavlink.MAVLink
    telemetry_rate_hz: float = 4.0
    on_ground: bool = False
    """Parked on the ground until a take-off (module docstring)."""
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
            "TKOFF_ALT": 50.0,
        }
        self.schedule = MessageSchedule(self.default_stream_rates())

    def default_stream_rates(self) -> dict[int, float]:
        """Rate (Hz) of each streamed message before any request: ``telemetry_rate_hz`` for all."""
        return dict.fromkeys(STREAMED_MESSAGES, float(self.telemetry_rate_hz))

    def update(self, now_s: float, state: AirframeState, wind_enu_mps: tuple[float, float]) -> None:
        """Once per physics step, before the airframe moves: controllers that run in the autopilot's own loop
        (here only the end of a take-off: the truth model's guidance law steers)."""
        self._takeoff_update(state)


    # ----------------------------------------------------------------- guidance

    @property
    def mode_name(self) -> str:
        """ArduPlane name of the current mode."""
        return ARDUPLANE_MODE_NAMES.get(self.mode, str(self.mode))

    def start(self, state: AirframeState) -> None:
        """Begin in the initial mode (LOITER about the start point), or disarmed and parked on the ground."""
        if self.on_ground:
            self.armed, self.mode, self.guidance = False, self.ground_mode, self._parked()
            return
        self._enter_mode(self.mode, state)

    def _flying(self) -> Guidance:
        """The guidance flown, or before :meth:`start` a loiter at the cruise altitude and airspeed."""
        return self.guidance or Guidance(kind="loiter", altitude_m=self.cruise_altitude_m,
                                         airspeed_mps=self.cruise_airspeed_mps, radius_m=self.airframe.loiter_radius_m)

    def _hold(self, kind: GuidanceKind, state: AirframeState, **changes) -> Guidance:
        return replace(self._flying(), kind=kind, max_turn_rate_rad_s=None, roll_command_rad=None, **changes)

    def _loiter_here(self, state: AirframeState) -> Guidance:
        point = (float(state.position_enu_m[0]), float(state.position_enu_m[1]))
        return self._hold("loiter", state, point_enu_m=point, radius_m=self.airframe.loiter_radius_m, clockwise=True)

    def _enter_mode(self, mode: int, state: AirframeState) -> None:
        if self._enter_on_ground(mode, state):
            return
        self.mode = mode
        self.guided_target_enu_m = None
        if mode == self.takeoff_mode:
            self._take_off(state)
        elif mode == GUIDED or mode in LOITER_MODES:
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
            result = self._arm(p[0] == 1, state)
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
            result = self._set_message_interval(int(p[0]), float(p[1]), now_s)
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

    def _set_message_interval(self, message_id: int, interval_us: float, now_s: float) -> int:
        return self.schedule.ardupilot_message_interval(message_id, interval_us, now_s)

    def _on_request_data_stream(self, msg, now_s: float, state: AirframeState) -> list:
        self.schedule.ardupilot_data_stream(msg.req_stream_id, msg.req_message_rate, msg.start_stop, now_s)
        return []  # ArduPilot sends no reply

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
        flying = self._flying()
        altitude = altitude if altitude is not None else flying.altitude_m
        if not mask & (_MASK_X | _MASK_Y):
            self._goto(state, msg.lat_int, msg.lon_int, altitude, radius_m=flying.radius_m)
        elif not mask & (_MASK_VX | _MASK_VY) and math.hypot(msg.vx, msg.vy) > 0:
            course = math.atan2(msg.vx, msg.vy)  # NED (north, east) velocity -> ENU course
            self.guided_target_enu_m = None
            self.guidance = self._hold("course", state, direction_rad=course, altitude_m=altitude)
        elif not mask & _MASK_YAW:
            self.guided_target_enu_m = None
            self.guidance = self._hold("heading", state, direction_rad=ned_yaw_from_enu_heading(msg.yaw),
                                       altitude_m=altitude)
        else:
            self.guidance = replace(flying, altitude_m=altitude)
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

    def _on_file_transfer_protocol(self, msg, now_s: float, state: AirframeState) -> list:
        reply = telemetry_messages.ftp_refusal(self.encoder, msg)
        return [] if reply is None else [reply]

    def _param_changed(self, name: str, value: float) -> None:
        if name == "AIRSPEED_CRUISE":
            self._change_speed(value)
