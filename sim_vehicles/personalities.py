"""Autopilot personalities by the name a scenario gives them (``[simulation] autopilot`` or a vehicle's ``autopilot``).

* ``ideal`` (:class:`~sim_vehicles.autopilot.SimAutopilot`): obeys every
  steering message at once, including position carrots; streams at the
  scenario's ``telemetry_rate_hz``.
* ``arduplane`` (:class:`~sim_vehicles.arduplane.ArduPlaneAutopilot`): ArduPlane's
  answers, guided heading PID and 1 Hz streams.
* ``px4`` (:class:`~sim_vehicles.px4.Px4Autopilot`): PX4's custom modes, OFFBOARD
  and its setpoint stream, UNSUPPORTED guided-change commands.

The names are :data:`gcs.config.simulation.AUTOPILOT_PERSONALITIES`, which the scenario
validation checks, so an unknown name never reaches :func:`make_autopilot`.
"""

from __future__ import annotations

from gcs.adapters.mavlink_wire import mavlink
from gcs.config.simulation import AirframeConfig
from gcs.core.geometry import LocalFrame
from sim_vehicles.arduplane import ArduPlaneAutopilot
from sim_vehicles.autopilot import SimAutopilot
from sim_vehicles.px4 import Px4Autopilot

__all__ = ["PERSONALITIES", "make_autopilot"]

PERSONALITIES: dict[str, type[SimAutopilot]] = {
    SimAutopilot.personality: SimAutopilot,
    ArduPlaneAutopilot.personality: ArduPlaneAutopilot,
    Px4Autopilot.personality: Px4Autopilot,
}


def make_autopilot(name: str, sysid: int, frame: LocalFrame, airframe: AirframeConfig, cruise_airspeed_mps: float,
                   cruise_altitude_m: float, encoder: mavlink.MAVLink, telemetry_rate_hz: float = 4.0,
                   on_ground: bool = False) -> SimAutopilot:
    """The autopilot of one vehicle (``on_ground``: disarmed and parked until a take-off); ValueError naming the
    known personalities for an unknown name."""
    try:
        cls = PERSONALITIES[name]
    except KeyError:
        raise ValueError(f"unknown autopilot {name!r}; expected one of: {', '.join(PERSONALITIES)}") from None
    return cls(sysid, frame, airframe, cruise_airspeed_mps, cruise_altitude_m, encoder, telemetry_rate_hz,
               on_ground=on_ground)
