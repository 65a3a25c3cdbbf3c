"""The ``arduplane`` autopilot personality: what ArduPlane 4.7 does with the ground station's commands.

Differences from the ``ideal`` autopilot (:mod:`sim_vehicles.autopilot`), each from
ArduPlane's own sources (file names under ``ArduPlane/`` unless said otherwise):

* **Position carrots are ignored horizontally.** In GUIDED,
  SET_POSITION_TARGET_GLOBAL_INT changes only the altitude (``GCS_Mavlink.cpp``,
  ``handle_set_position_target_global_int``); lat/lon, velocity and yaw are
  dropped, and the POSITION_TARGET_GLOBAL_INT echo keeps showing the guided
  waypoint. Outside GUIDED the message is dropped silently.
* **Guided heading** (``MAV_CMD_GUIDED_CHANGE_HEADING``, GUIDED only, else
  FAILED; param2 outside [0, 360) or param1 not 0/1/2 DENIED; param1 2 clears
  it): the bank demand comes from the GUIDED_ PID on the heading (or course)
  error, limited by atan(param3 / g) and ROLL_LIMIT_DEG (``mode_guided.cpp``,
  :mod:`sim_vehicles.guided_heading`); it runs every physics step
  (:meth:`ArduPlaneAutopilot.update`) and stays in force until the mode changes
  or a DO_REPOSITION (which clears ``target_heading_type``). The same heading sent
  again is accepted and changes nothing. A guided "fly to" (MISSION_ITEM_INT
  current 2) moves the waypoint but leaves a heading in force, as
  ``ModeGuided::handle_guided_request`` does.
* **GUIDED_CHANGE_ALTITUDE** (GUIDED only, else FAILED; z of -1 or 0 DENIED) is
  held until the next mode change: it overrides the altitude of any later
  waypoint or carrot (``ModeGuided::update_target_altitude``; ``mode.cpp``
  ``Mode::enter`` resets it with the heading and airspeed targets).
* **GUIDED_CHANGE_SPEED**: param1 must be 0 (airspeed; else DENIED), the speed
  inside [AIRSPEED_MIN, AIRSPEED_MAX] (else FAILED, ``handle_change_airspeed``).
  **DO_CHANGE_SPEED** only in GUIDED or AUTO (else FAILED,
  ``handle_command_DO_CHANGE_SPEED``). A disarm in flight without the force code
  is FAILED (``libraries/GCS_MAVLink/GCS_Common.cpp``).
* **Streams at 1 Hz until asked**: the SRn_EXT_STAT, SRn_POSITION, SRn_EXTRA1 and
  SRn_EXTRA2 defaults are 1 Hz (``GCS_Mavlink.cpp``, "default stream rates to
  1Hz"); REQUEST_DATA_STREAM and SET_MESSAGE_INTERVAL change them
  (:mod:`sim_vehicles.streams`).

* **The turn a bank gives.** ArduPlane SITL's ``plane`` model flies the bank its roll
  controller is asked for, but turns at only a share of the coordinated-turn rate
  ``g tan(phi) / V`` for that bank (sideslip: its rudder mix does not coordinate the
  turn fully). The personality asks the airframe for the bank whose coordinated turn is
  that share, :data:`TURN_EFFICIENCY` of the demanded bank's, fitted to SITL's course
  steps by ``gcs-bench autopilots --identify --sitl`` (docs/benchmarks.md).

Mode numbers, HEARTBEAT and the other commands are the ideal autopilot's, which
already uses ArduPlane's numbers and results.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink, ned_yaw_from_enu_heading
from gcs.core.geometry import wrap_angle
from sim_vehicles.autopilot import GUIDED, SimAutopilot
from sim_vehicles.guided_heading import MIN_ACCEL_LIMIT_MPS2, GuidedHeadingPid, bank_limit_cd
from sim_vehicles.streams import STREAMED_MESSAGES
from sim_vehicles.truth.fixed_wing import AirframeState

__all__ = ["ArduPlaneAutopilot", "GuidedHeading", "TURN_EFFICIENCY"]

TURN_EFFICIENCY = 0.71
"""The turn rate ArduPlane SITL's plane achieves at a bank, as a share of the coordinated turn ``g tan(phi) / V``
(module docstring): the personality's course loop is then the real one's, gain and largest turn rate
(:func:`benchmarks.autopilots.fit_turn_efficiency`)."""
_AUTO = ARDUPLANE_MODES["AUTO"]
_HEADING_TYPE_COG, _HEADING_TYPE_HEADING, _HEADING_TYPE_DEFAULT = 0, 1, 2
_PID_PARAMS = {"GUIDED_P": "kp", "GUIDED_I": "ki", "GUIDED_D": "kd", "GUIDED_IMAX": "imax",
               "GUIDED_FLTE": "filt_e_hz", "GUIDED_FLTD": "filt_d_hz"}


@dataclass(frozen=True)
class GuidedHeading:
    """A GUIDED_CHANGE_HEADING in force: ENU direction, whether it is a heading (else a course over ground),
    and the lateral acceleration limit (m/s^2, at least 0.05)."""

    direction_rad: float
    is_heading: bool
    accel_limit_mps2: float
    requested_deg: float


@dataclass
class ArduPlaneAutopilot(SimAutopilot):
    """A simulated vehicle that answers as ArduPlane does (module docstring)."""

    personality = "arduplane"
    disarm_in_flight_result = mavlink.MAV_RESULT_FAILED
    heading_target: GuidedHeading | None = None
    altitude_override_m: float | None = None
    pid: GuidedHeadingPid = field(default_factory=GuidedHeadingPid)
    pid_limited: bool = False
    bank_demand_cd: float = 0.0
    turn_efficiency: float = TURN_EFFICIENCY
    _last_update_s: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for name, attribute in _PID_PARAMS.items():
            self.params[name] = float(getattr(self.pid, attribute))

    def default_stream_rates(self) -> dict[int, float]:
        """1 Hz for every streamed message: ArduPlane's SRn_* defaults."""
        return dict.fromkeys(STREAMED_MESSAGES, 1.0)

    def _param_changed(self, name: str, value: float) -> None:
        if name in _PID_PARAMS:
            setattr(self.pid, _PID_PARAMS[name], value)
        else:
            super()._param_changed(name, value)

    # ------------------------------------------------------------- the loop

    def update(self, now_s: float, state: AirframeState, wind_enu_mps: tuple[float, float]) -> None:
        """Run the guided heading PID (when a heading is in force) and put its bank demand into the guidance; the
        end of a take-off."""
        self._takeoff_update(state)
        dt = 0.0 if self._last_update_s is None else max(now_s - self._last_update_s, 0.0)
        self._last_update_s = now_s
        target = self.heading_target
        if self.mode != GUIDED or target is None or self.guidance is None:
            return
        current = state.heading_rad if target.is_heading else state.course_rad(wind_enu_mps)
        error = wrap_angle(target.direction_rad - current)  # ENU: positive turns counter-clockwise
        limit = bank_limit_cd(target.accel_limit_mps2, self.params["ROLL_LIMIT_DEG"])
        desired = self.pid.update_error(error, dt, self.pid_limited)
        self.pid_limited = abs(desired) >= limit
        self.bank_demand_cd = min(max(desired, -limit), limit)
        bank = math.atan(self.turn_efficiency * math.tan(math.radians(self.bank_demand_cd / 100.0)))
        self.guidance = replace(self.guidance, roll_command_rad=bank, direction_rad=target.direction_rad)

    # ------------------------------------------------------------- commands

    def _enter_mode(self, mode: int, state: AirframeState) -> None:
        self.heading_target = None
        self.altitude_override_m = None
        self.pid.reset()
        super()._enter_mode(mode, state)
        self.guidance = replace(self._flying(), airspeed_mps=self.cruise_airspeed_mps)

    def _command(self, msg, command: int, p: tuple, frame: int | None, state: AirframeState, now_s: float) -> list:
        if command == mavlink.MAV_CMD_GUIDED_CHANGE_SPEED:
            return self._ack(msg, command, self._guided_speed(p))
        if command == mavlink.MAV_CMD_GUIDED_CHANGE_ALTITUDE:
            return self._ack(msg, command, self._guided_altitude(p, frame))
        if command == mavlink.MAV_CMD_DO_CHANGE_SPEED and self.mode not in (GUIDED, _AUTO):
            return self._ack(msg, command, mavlink.MAV_RESULT_FAILED)
        replies = super()._command(msg, command, p, frame, state, now_s)
        if command == mavlink.MAV_CMD_DO_REPOSITION and replies[0].result == mavlink.MAV_RESULT_ACCEPTED:
            self._clear_heading()
            self._apply_altitude_override()
        return replies

    def _guided_speed(self, p: tuple) -> int:
        if self.mode != GUIDED:
            return mavlink.MAV_RESULT_FAILED
        if int(p[0]) != 0:
            return mavlink.MAV_RESULT_DENIED  # only SPEED_TYPE_AIRSPEED
        if not self.params["AIRSPEED_MIN"] <= p[1] <= self.params["AIRSPEED_MAX"]:
            return mavlink.MAV_RESULT_FAILED
        self.guidance = replace(self._flying(), airspeed_mps=float(p[1]))
        return mavlink.MAV_RESULT_ACCEPTED

    def _guided_altitude(self, p: tuple, frame: int | None) -> int:
        if self.mode != GUIDED:
            return mavlink.MAV_RESULT_FAILED
        z = float(p[6])
        if z in (-1.0, 0.0):
            return mavlink.MAV_RESULT_DENIED
        altitude = self._altitude_from(frame if frame is not None else mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, z)
        if altitude is None:
            return mavlink.MAV_RESULT_DENIED
        self.altitude_override_m = altitude
        self._apply_altitude_override()
        return mavlink.MAV_RESULT_ACCEPTED

    def _apply_altitude_override(self) -> None:
        if self.altitude_override_m is not None and self.guidance is not None:
            self.guidance = replace(self.guidance, altitude_m=self.altitude_override_m)

    def _clear_heading(self) -> None:
        if self.heading_target is not None:
            self.heading_target = None
            self.guidance = replace(self._flying(), roll_command_rad=None)

    def _change_heading(self, p: tuple, state: AirframeState) -> int:
        if self.mode != GUIDED:
            return mavlink.MAV_RESULT_FAILED
        if not 0.0 <= p[1] < 360.0:
            return mavlink.MAV_RESULT_DENIED
        kind = int(p[0])
        if kind == _HEADING_TYPE_DEFAULT:
            self._clear_heading()
            return mavlink.MAV_RESULT_ACCEPTED
        if kind not in (_HEADING_TYPE_COG, _HEADING_TYPE_HEADING):
            return mavlink.MAV_RESULT_DENIED
        target = GuidedHeading(ned_yaw_from_enu_heading(math.radians(p[1])), kind == _HEADING_TYPE_HEADING,
                               max(float(p[2]), MIN_ACCEL_LIMIT_MPS2), float(p[1]))
        if self.heading_target is not None and target.requested_deg == self.heading_target.requested_deg:
            return mavlink.MAV_RESULT_ACCEPTED  # "we're already on it"
        self.pid.reset_i()
        self.heading_target = target
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_position_target_global_int(self, msg, now_s: float, state: AirframeState) -> list:
        if self.mode != GUIDED:
            self.counters["position_target_outside_guided"] += 1
            return []
        self.counters["position_target_horizontal_ignored"] += 1
        if msg.type_mask & 4 or self.altitude_override_m is not None:  # z ignored, or GUIDED_CHANGE_ALTITUDE holds
            return []
        altitude = self._altitude_from(msg.coordinate_frame, msg.alt)
        if altitude is None:
            self.counters["position_target_bad_frame"] += 1
            return []
        self.guidance = replace(self._flying(), altitude_m=altitude)
        return []

    def _goto(self, state: AirframeState, lat_e7: int, lon_e7: int, altitude_m: float,
              radius_m: float | None = None, clockwise: bool = True) -> None:
        super()._goto(state, lat_e7, lon_e7, altitude_m, radius_m, clockwise)
        self._apply_altitude_override()
