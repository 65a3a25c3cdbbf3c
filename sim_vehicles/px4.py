"""The ``px4`` autopilot personality: what PX4 fixed-wing does with the ground station's commands.

Differences from the ``ideal`` autopilot (:mod:`sim_vehicles.autopilot`), each from
PX4's sources (paths under ``src/modules/``) or docs/mavlink.md:

* **HEARTBEAT** says MAV_AUTOPILOT_PX4 (12); ``custom_mode`` is PX4's
  ``px4_custom_mode`` union, ``main_mode << 16 | sub_mode << 24`` (MANUAL 1,
  ALTCTL 2, POSCTL 3, AUTO 4 with sub-modes TAKEOFF 2 / LOITER 3 / MISSION 4 /
  RTL 5 / LAND 6, ACRO 5, OFFBOARD 6, STABILIZED 7). MAV_CMD_DO_SET_MODE takes
  param2 = main and param3 = sub mode; a switch the vehicle cannot make is
  TEMPORARILY_REJECTED (``commander/Commander.cpp``, ``handle_command``).
* **OFFBOARD** needs the setpoint stream first: the switch is rejected unless a
  setpoint came within COM_OF_LOSS_T (default 1 s), and once in OFFBOARD a gap
  longer than COM_OF_LOSS_T drops the vehicle out
  (``commander/HealthAndArmingChecks/checks/offboardCheck.cpp``) into the
  COM_OBL_RC_ACT action: 0 Position (the default; with centred sticks a
  fixed-wing holds its course and altitude), 3 Return, 5 Hold. (PX4's failsafe
  delay COM_FAIL_ACT_T is not modelled: the action is immediate.)
* **SET_POSITION_TARGET_GLOBAL_INT** (frames 5, 6, 11 only): x, y and z all
  enabled is a position setpoint that the vehicle flies to (the carrot steers),
  then circles at NAV_LOITER_RAD; else vx and vy enabled is a course
  ``atan2(vy, vx)``; yaw is never used by a fixed-wing. Every such setpoint
  keeps the offboard signal alive, in any mode; it steers only in OFFBOARD.
* **GUIDED_CHANGE_HEADING / _SPEED / _ALTITUDE are UNSUPPORTED** (ArduPilot
  dialect commands PX4's commander does not know). DO_REPOSITION (COMMAND_INT or
  COMMAND_LONG) switches to Hold at the point. A disarm in flight is
  TEMPORARILY_REJECTED.
* **Streams** at PX4's "normal" mode defaults (``mavlink/mavlink_main.cpp``,
  ``configure_streams_to_default``): GLOBAL_POSITION_INT 5 Hz, ATTITUDE 15 Hz,
  GPS_RAW_INT 1 Hz, VFR_HUD 4 Hz, POSITION_TARGET_GLOBAL_INT 1 Hz;
  SET_MESSAGE_INTERVAL changes them, REQUEST_DATA_STREAM is ignored
  (``mavlink/mavlink_receiver.cpp`` has no handler for it).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

from gcs.adapters.mavlink_wire import mavlink
from sim_vehicles.autopilot import SimAutopilot
from sim_vehicles.truth.fixed_wing import AirframeState

__all__ = ["Px4Autopilot", "PX4_MODES", "px4_custom_mode"]

log = logging.getLogger(__name__)


def px4_custom_mode(main_mode: int, sub_mode: int = 0) -> int:
    """HEARTBEAT.custom_mode of PX4's (main, sub) mode."""
    return (main_mode << 16) | (sub_mode << 24)


PX4_MODES: dict[str, int] = {
    "MANUAL": px4_custom_mode(1), "ALTCTL": px4_custom_mode(2), "POSCTL": px4_custom_mode(3),
    "AUTO_TAKEOFF": px4_custom_mode(4, 2), "AUTO_LOITER": px4_custom_mode(4, 3),
    "AUTO_MISSION": px4_custom_mode(4, 4), "AUTO_RTL": px4_custom_mode(4, 5), "AUTO_LAND": px4_custom_mode(4, 6),
    "ACRO": px4_custom_mode(5), "OFFBOARD": px4_custom_mode(6), "STABILIZED": px4_custom_mode(7),
}
PX4_MODE_NAMES = {number: name for name, number in PX4_MODES.items()}
OFFBOARD, HOLD, RTL, POSCTL = PX4_MODES["OFFBOARD"], PX4_MODES["AUTO_LOITER"], PX4_MODES["AUTO_RTL"], PX4_MODES["POSCTL"]
_COURSE_HOLD_MODES = frozenset(PX4_MODES[name] for name in ("MANUAL", "ALTCTL", "POSCTL", "ACRO", "STABILIZED"))
_FLYABLE = _COURSE_HOLD_MODES | {OFFBOARD, HOLD, RTL}
_LOSS_ACTIONS = {0: POSCTL, 3: RTL, 5: HOLD}
_SETPOINT_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                              mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_MASK_XYZ, _MASK_VXY = 1 | 2 | 4, 8 | 16
_GUIDED_CHANGE = frozenset({mavlink.MAV_CMD_GUIDED_CHANGE_HEADING, mavlink.MAV_CMD_GUIDED_CHANGE_SPEED,
                            mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE})


@dataclass
class Px4Autopilot(SimAutopilot):
    """A simulated vehicle that answers as PX4 fixed-wing does (module docstring)."""

    personality = "px4"
    disarm_in_flight_result = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    takeoff_mode = PX4_MODES["AUTO_TAKEOFF"]
    takeoff_altitude_param = "MIS_TAKEOFF_ALT"
    ground_mode = PX4_MODES["AUTO_LOITER"]
    mode: int = HOLD
    last_setpoint_s: float | None = None
    last_setpoint: object | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self.params = {
            "MAV_SYS_ID": float(self.sysid),
            "FW_AIRSPD_TRIM": float(self.cruise_airspeed_mps),
            "FW_AIRSPD_MIN": float(self.airframe.min_airspeed_mps),
            "FW_AIRSPD_MAX": float(self.airframe.max_airspeed_mps),
            "FW_R_LIM": math.degrees(self.airframe.max_bank_rad),
            "NAV_LOITER_RAD": float(self.airframe.loiter_radius_m),
            "COM_OF_LOSS_T": 1.0,
            "COM_OBL_RC_ACT": 0.0,
            "MIS_TAKEOFF_ALT": 50.0,
        }

    def default_stream_rates(self) -> dict[int, float]:
        """PX4's normal-mode stream rates."""
        return {mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 5.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 15.0,
                mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0, mavlink.MAVLINK_MSG_ID_VFR_HUD: 4.0,
                mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0}

    @property
    def mode_name(self) -> str:
        """PX4 name of the current mode."""
        return PX4_MODE_NAMES.get(self.mode, str(self.mode))

    def _param_changed(self, name: str, value: float) -> None:
        if name == "FW_AIRSPD_TRIM":
            self._change_speed(value)

    def _signal_fresh(self, now_s: float) -> bool:
        return self.last_setpoint_s is not None and now_s - self.last_setpoint_s <= self.params["COM_OF_LOSS_T"]

    # ------------------------------------------------------------- the loop

    def update(self, now_s: float, state: AirframeState, wind_enu_mps: tuple[float, float]) -> None:
        """Offboard loss: out of OFFBOARD into COM_OBL_RC_ACT once the setpoints stop for COM_OF_LOSS_T; the end
        of a take-off."""
        self._takeoff_update(state)
        if self.mode == OFFBOARD and not self._signal_fresh(now_s):
            action = _LOSS_ACTIONS.get(int(self.params["COM_OBL_RC_ACT"]), POSCTL)
            log.info("vehicle %d: offboard signal lost, %s", self.sysid, PX4_MODE_NAMES[action])
            self.counters["offboard_lost"] += 1
            self._enter_mode(action, state)

    # ------------------------------------------------------------- modes

    def _enter_mode(self, mode: int, state: AirframeState) -> None:
        if self._enter_on_ground(mode, state):
            return
        self.mode = mode
        self.guided_target_enu_m = None
        if mode == self.takeoff_mode:
            self._take_off(state)
        elif mode == HOLD:
            self.guidance = self._loiter_here(state)
        elif mode == RTL:
            self.guidance = self._hold("loiter", state, point_enu_m=(0.0, 0.0), radius_m=self.airframe.loiter_radius_m,
                                       clockwise=True)
        else:  # a course-hold mode with centred sticks; OFFBOARD until its setpoint is applied
            self.guidance = self._hold("course", state, direction_rad=state.heading_rad)
        if mode == OFFBOARD and self.last_setpoint is not None:
            self._apply_setpoint(self.last_setpoint, state)

    def _takeoff_done(self, state: AirframeState, altitude_m: float) -> None:
        """PX4 switches to Hold (AUTO.LOITER) at the take-off altitude."""
        self._enter_mode(HOLD, state)

    def _set_mode(self, mode: int, state: AirframeState, now_s: float | None = None) -> int:
        if mode not in _FLYABLE and not (mode == self.takeoff_mode and self.on_ground):
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED  # no mission, and no take-off or landing in flight
        if mode == OFFBOARD and (now_s is None or not self._signal_fresh(now_s)):
            self.counters["offboard_rejected"] += 1
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        if mode != self.mode:
            log.info("vehicle %d: mode %s -> %s", self.sysid, self.mode_name, PX4_MODE_NAMES[mode])
            self._enter_mode(mode, state)
        return mavlink.MAV_RESULT_ACCEPTED

    def _command(self, msg, command: int, p: tuple, frame: int | None, state: AirframeState, now_s: float) -> list:
        if command == mavlink.MAV_CMD_DO_SET_MODE:
            if not int(p[0]) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return self._ack(msg, command, mavlink.MAV_RESULT_TEMPORARILY_REJECTED)
            return self._ack(msg, command, self._set_mode(px4_custom_mode(int(p[1]), int(p[2])), state, now_s))
        if command in _GUIDED_CHANGE:
            return self._ack(msg, command, mavlink.MAV_RESULT_UNSUPPORTED)
        return super()._command(msg, command, p, frame, state, now_s)

    def _on_set_mode(self, msg, now_s: float, state: AirframeState) -> list:
        if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self._set_mode(int(msg.custom_mode), state, now_s)
        return []

    def _reposition(self, p: tuple, frame: int | None, state: AirframeState) -> int:
        lat_e7, lon_e7 = (int(p[4]), int(p[5])) if frame is not None else (round(p[4] * 1e7), round(p[5] * 1e7))
        altitude = self._altitude_from(frame if frame is not None else mavlink.MAV_FRAME_GLOBAL, p[6])
        if altitude is None:
            return mavlink.MAV_RESULT_DENIED
        self._set_mode(HOLD, state)
        self._goto(state, lat_e7, lon_e7, altitude)
        return mavlink.MAV_RESULT_ACCEPTED

    def _set_message_interval(self, message_id: int, interval_us: float, now_s: float) -> int:
        return self.schedule.px4_message_interval(message_id, interval_us, now_s)

    def _on_request_data_stream(self, msg, now_s: float, state: AirframeState) -> list:
        return []  # not handled by PX4's MavlinkReceiver

    def heartbeat(self):
        """HEARTBEAT: fixed-wing, PX4, PX4's custom mode, armed flag, ACTIVE in flight."""
        auto = mavlink.MAV_MODE_FLAG_AUTO_ENABLED if self.mode in (OFFBOARD, HOLD, RTL) else 0
        base = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | auto
                | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0))
        status = mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY
        return self.encoder.heartbeat_encode(mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, base, self.mode,
                                             status)

    def echoed_target(self) -> tuple[float, float, float] | None:
        """The position setpoint being flown (OFFBOARD) or the Hold point."""
        return self.guided_target_enu_m

    # ------------------------------------------------------------- setpoints

    def _on_set_position_target_global_int(self, msg, now_s: float, state: AirframeState) -> list:
        if msg.coordinate_frame not in _SETPOINT_FRAMES:
            self.counters["position_target_bad_frame"] += 1
            return []
        if msg.type_mask & _MASK_XYZ and msg.type_mask & _MASK_VXY:
            self.counters["position_target_unusable"] += 1
            return []
        self.last_setpoint_s, self.last_setpoint = now_s, msg
        if self.mode == OFFBOARD:
            self._apply_setpoint(msg, state)
        return []

    def _apply_setpoint(self, msg, state: AirframeState) -> None:
        altitude = self._altitude_from(msg.coordinate_frame, msg.alt)
        if altitude is None:  # (not one of _SETPOINT_FRAMES, which are all global)
            self.counters["position_target_bad_frame"] += 1
            return
        if not msg.type_mask & _MASK_XYZ:
            self._goto(state, msg.lat_int, msg.lon_int, altitude, radius_m=self.params["NAV_LOITER_RAD"])
        else:
            self.guided_target_enu_m = None
            course = math.atan2(msg.vx, msg.vy)  # NED (north, east) velocity -> ENU course
            self.guidance = replace(self._hold("course", state, direction_rad=course),
                                    altitude_m=self._flying().altitude_m if msg.type_mask & 4 else altitude)
