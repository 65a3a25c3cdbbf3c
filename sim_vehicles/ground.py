"""Simulated vehicles that start on the ground: parked and disarmed until armed in their take-off mode.

With ``[simulation] start_on_ground`` the vehicle starts
disarmed and parked at home height, in MANUAL. ``MAV_CMD_COMPONENT_ARM_DISARM``
arms (and disarms) it there. It stays parked in every mode but TAKEOFF (13;
PX4: AUTO.TAKEOFF), which, once armed, climbs on the current heading at the
cruise airspeed to TKOFF_ALT (50 m, ArduPlane's ``ModeTakeoff`` default; PX4:
MIS_TAKEOFF_ALT) and then loiters there, as ArduPlane's TAKEOFF mode does. The
take-off run is not modelled: the plane leaves the ground at once, its airspeed
rising with the airframe's time constant.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import replace

from gcs.adapters.mavlink_wire import mavlink
from gcs.config.simulation import AirframeConfig
from sim_vehicles.truth.fixed_wing import AirframeState, Guidance

__all__ = ["GroundStart"]

log = logging.getLogger(__name__)


class GroundStart:
    """The on-ground behaviour of :class:`~sim_vehicles.autopilot.SimAutopilot` (a mixin: it uses the
    autopilot's mode, arming, guidance, parameters and ``takeoff_mode``/``takeoff_altitude_param``)."""

    sysid: int
    airframe: AirframeConfig
    cruise_airspeed_mps: float
    mode: int
    armed: bool
    on_ground: bool
    guidance: Guidance | None
    guided_target_enu_m: tuple[float, float, float] | None
    params: dict[str, float]
    takeoff_mode: int
    takeoff_altitude_param: str
    disarm_in_flight_result: int
    _loiter_here: Callable[[AirframeState], Guidance]

    def _takeoff_update(self, state: AirframeState) -> None:
        """A take-off that has reached its altitude loiters there."""
        if self.mode != self.takeoff_mode or self.on_ground or self.guidance is None or self.guidance.kind == "loiter":
            return
        if state.position_enu_m[2] >= self.guidance.altitude_m - 1.0:
            log.info("vehicle %d: take-off complete at %.0f m", self.sysid, state.position_enu_m[2])
            self._takeoff_done(state, self.guidance.altitude_m)

    def _takeoff_done(self, state: AirframeState, altitude_m: float) -> None:
        """ArduPlane's TAKEOFF mode loiters at the take-off altitude (``altitude_m``) once there (and stays in
        TAKEOFF)."""
        self.guidance = replace(self._loiter_here(state), altitude_m=altitude_m)

    def _parked(self) -> Guidance:
        return Guidance(kind="parked", altitude_m=0.0, airspeed_mps=0.0)

    def _take_off(self, state: AirframeState) -> None:
        """Leave the ground: climb on the current heading to the take-off altitude."""
        self.on_ground = False
        altitude = self.params.get(self.takeoff_altitude_param, 50.0)
        log.info("vehicle %d: taking off to %.0f m", self.sysid, altitude)
        self.guidance = Guidance(kind="heading", altitude_m=altitude, airspeed_mps=self.cruise_airspeed_mps,
                                 direction_rad=state.heading_rad, radius_m=self.airframe.loiter_radius_m)

    def _arm(self, arm: bool, state: AirframeState) -> int:
        """Arm (param1 1) or disarm: on the ground both; in flight arming is a no-op and disarming refused."""
        if not self.on_ground:
            return mavlink.MAV_RESULT_ACCEPTED if arm else self.disarm_in_flight_result
        self.armed = arm
        log.info("vehicle %d: %s on the ground", self.sysid, "armed" if arm else "disarmed")
        if arm and self.mode == self.takeoff_mode:
            self._take_off(state)
        return mavlink.MAV_RESULT_ACCEPTED

    def _enter_on_ground(self, mode: int, state: AirframeState) -> bool:
        """Enter ``mode`` as a plane on the ground does (parked, or off in TAKEOFF once armed); False in flight."""
        if not self.on_ground:
            return False
        self.mode = mode
        self.guided_target_enu_m = None
        if mode == self.takeoff_mode and self.armed:
            self._take_off(state)
        else:
            self.guidance = self._parked()
        return True

