"""What a simulated autopilot sends on its own: HEARTBEAT, SYS_STATUS, requested messages and its streams."""

from __future__ import annotations

from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink
from gcs.core.geometry import LocalFrame
from sim_vehicles import telemetry_messages
from sim_vehicles.truth.fixed_wing import AirframeState
from sim_vehicles.streams import MessageSchedule
from sim_vehicles.truth.gps import GpsReading

__all__ = ["Egress"]

GUIDED = ARDUPLANE_MODES["GUIDED"]
"""The mode in which the guided target is echoed."""


class Egress:
    """The outgoing messages of :class:`~sim_vehicles.autopilot.SimAutopilot` (a mixin: it uses the autopilot's
    encoder, frame, mode, arming, guided target and stream schedule)."""

    sysid: int
    frame: LocalFrame
    encoder: mavlink.MAVLink
    mode: int
    armed: bool
    guided_target_enu_m: tuple[float, float, float] | None
    schedule: MessageSchedule

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
        """SYS_STATUS (every sensor healthy, no fence breached)."""
        return telemetry_messages.sys_status(self.encoder)

    def autopilot_version(self):
        """AUTOPILOT_VERSION."""
        return telemetry_messages.autopilot_version(self.encoder, self.sysid)

    def home_position(self, now_s: float):
        """HOME_POSITION: the scenario origin at ground level."""
        return telemetry_messages.home_position(self.encoder, self.frame, now_s)

    def echoed_target(self) -> tuple[float, float, float] | None:
        """The guided target POSITION_TARGET_GLOBAL_INT echoes (ENU metres), or None for no echo."""
        return self.guided_target_enu_m if self.mode == GUIDED else None

    def streams(self, now_s: float, state: AirframeState, gps: GpsReading, wind_enu_mps: tuple[float, float]) -> list:
        """The position/attitude messages due now by the stream schedule (:mod:`sim_vehicles.streams`)."""
        target = self.echoed_target()
        messages = (telemetry_messages.stream_message(self.encoder, self.frame, message_id, now_s, state, gps,
                                                      wind_enu_mps, target)
                    for message_id in self.schedule.due(now_s))
        return [message for message in messages if message is not None]
