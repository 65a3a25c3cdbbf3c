"""What the daemon sends each vehicle, and when (pure): :func:`due_actions`.

The encoding (docs/mavlink.md, "What the daemon sends"), chosen
from the autopilot the vehicle's HEARTBEAT names:

* to every vehicle with a recent HEARTBEAT, once its link is up and again every
  :data:`STREAM_CHECK_PERIOD_S` while a rate falls short:
  ``MAV_CMD_SET_MESSAGE_INTERVAL`` for GLOBAL_POSITION_INT and ATTITUDE at
  ``stream_rate_hz`` (ArduPlane streams them at 1 Hz until asked);
* for a vehicle with a command:

  - ``MAV_CMD_DO_SET_MODE`` to GUIDED (ArduPilot numbering, custom mode 15;
    OFFBOARD for a PX4 peer) at most once per second until the HEARTBEAT
    shows it, and only while the takeover guard allows (:class:`~gcs.adapters.mavlink_takeover.Takeover`:
    armed, and at least ``min_altitude_m`` above home); with ``takeoff``, a
    vehicle held back by the guard is armed (``MAV_CMD_COMPONENT_ARM_DISARM``)
    and switched to its own take-off mode (ArduPlane TAKEOFF, PX4
    AUTO.TAKEOFF), each at most once per second, until it is high enough;
  - to an ArduPilot peer in GUIDED, ``COMMAND_INT MAV_CMD_GUIDED_CHANGE_HEADING``
    (course over ground, degrees NED in [0, 360), lateral acceleration limit
    ``margin V omega_max``) when the course moved by more than 0.5 degree since
    the last one sent, and ``GUIDED_CHANGE_SPEED`` / ``GUIDED_CHANGE_ALTITUDE``
    when those change; all three are sent again after the vehicle (re-)enters
    GUIDED or its link comes back. No carrots: ArduPlane takes only their
    altitude (docs/mavlink.md);
  - to any other peer (PX4), the carrot ``SET_POSITION_TARGET_GLOBAL_INT``
    (frame ``GLOBAL_RELATIVE_ALT_INT``, type_mask ``0x09F8``) at
    ``carrot_rate_hz``: the latest position plus ``D`` metres along the commanded
    course, ``D = max(3 V / omega_max, 15 s * V)`` (:func:`carrot_distance_m`),
    altitude the commanded one, yaw the course in NED. It streams before
    the OFFBOARD request too, as PX4 requires;
* to a vehicle the daemon took over and lets go of (:meth:`SendMemory.let_go`:
  the daemon stops, or the target has been lost for long), one
  ``MAV_CMD_DO_SET_MODE`` to the hand-back mode, RTL or LOITER (PX4: AUTO.RTL,
  AUTO.LOITER), and nothing more until it is commanded again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from gcs.adapters.mavlink_link import (GUIDED, PX4_OFFBOARD_MAIN_MODE, STREAMED_TELEMETRY, HeadingCommand,
                                       VehicleLink, in_guided_mode)
from gcs.adapters.mavlink_messages import (Action, Carrot, ChangeAltitude, ChangeHeading, ChangeSpeed, MessageInterval,
                                           ModeRequest, course_param_deg)
from gcs.adapters.mavlink_takeover import (MODE_REQUEST_PERIOD_S, Takeover, handback_request, takeoff_action,
                                           takeover_blocked)
from gcs.adapters.mavlink_wire import mavlink, ned_yaw_from_enu_heading
from gcs.core.geometry import LocalFrame, wrap_angle

__all__ = ["SendMemory", "carrot_distance_m", "next_due", "stream_requests", "carrot_for", "due_actions",
           "DEFAULT_STREAM_RATE_HZ", "DEFAULT_MAX_TURN_RATE_RAD_S"]

CARROT_LOOKAHEAD_S = 15.0
CARROT_TURN_RADII = 3.0
DEFAULT_MAX_TURN_RATE_RAD_S = 0.2
"""Turn-rate bound of a vehicle not given one (wang2012's UAVs)."""
LATERAL_ACCEL_MARGIN = 1.25
"""GUIDED_CHANGE_HEADING's acceleration limit over ``V omega_max``: ArduPlane's bank limit is
``atan(a / g)``, so at exactly ``V omega_max`` a plan at full turn rate would leave no bank to
correct with; the turn rate asked is bounded by the steering itself (:mod:`gcs.core.steering`)."""
HEADING_RESEND_RAD = math.radians(0.5)
AIRSPEED_RESEND_MPS = 0.1
ALTITUDE_RESEND_M = 0.5
DEFAULT_STREAM_RATE_HZ = 5.0
"""The rate asked for GLOBAL_POSITION_INT and ATTITUDE (``[daemon] stream_rate_hz``)."""
STREAM_CHECK_PERIOD_S = 5.0
"""How long after asking the arrival rates are checked, and how often after that."""
STREAM_ARRIVAL_FRACTION = 0.8
"""A stream arriving slower than this share of the rate asked is asked again (and counted)."""


def carrot_distance_m(speed_mps: float, max_turn_rate_rad_s: float) -> float:
    """How far ahead the carrot goes: ``D = max(3 R, 15 s V)`` with turn radius ``R = V / omega_max``.

    At least three turn radii and 15 s of flight (docs/mavlink.md), so that a
    vehicle never reaches (and loiters about) a carrot between sends.
    """
    return max(CARROT_TURN_RADII * speed_mps / max_turn_rate_rad_s, CARROT_LOOKAHEAD_S * speed_mps)


@dataclass(frozen=True)
class SendMemory:
    """What was last sent to one vehicle (None: must be sent again), and the last check of its streams."""

    next_carrot_s: float = -math.inf
    mode_request_s: float = -math.inf
    heading_rad: float | None = None
    airspeed_mps: float | None = None
    altitude_m: float | None = None
    streams_asked_s: float | None = None
    arrivals_when_asked: tuple[int, ...] = ()
    stream_rates_hz: tuple[float, ...] | None = None
    """The arrival rates of :data:`STREAMED_TELEMETRY` measured at the last check (None before one)."""
    took_over: bool = False
    """The vehicle was seen in GUIDED/OFFBOARD while the daemon commanded it."""
    handback_due: bool = False
    blocked: str | None = None
    """Why the last mode request was held back (:func:`takeover_blocked`), None when it was not."""

    def let_go(self) -> SendMemory:
        """The daemon lets go of the vehicle: the hand-back mode is asked once if it had taken it over."""
        return replace(self, handback_due=self.took_over, took_over=False)

    def forget_guided(self) -> SendMemory:
        """After a (re-)entry into GUIDED or a link's return: the GUIDED_CHANGE_* commands go out again."""
        return replace(self, heading_rad=None, airspeed_mps=None, altitude_m=None)

    def forget_streams(self) -> SendMemory:
        """After a link's return: the stream rates are asked for again."""
        return replace(self, streams_asked_s=None, arrivals_when_asked=(), stream_rates_hz=None)


def next_due(due_s: float, now_s: float, period_s: float) -> float:
    """The next firing of a periodic send: drift-free, but never a burst after a stall."""
    following = due_s + period_s
    return following if following > now_s else now_s + period_s


def carrot_for(frame: LocalFrame, link: VehicleLink, command: HeadingCommand, max_turn_rate_rad_s: float,
               now_s: float) -> Carrot:
    """The carrot from the latest position: ``D`` metres along the commanded course, at the commanded altitude.

    ``V`` in ``D`` is the larger of the commanded airspeed and the measured ground speed.
    """
    assert link.position_enu_m is not None
    speed = command.airspeed_mps
    if link.velocity_enu_mps is not None:
        speed = max(speed, float(np.hypot(link.velocity_enu_mps[0], link.velocity_enu_mps[1])))
    distance = carrot_distance_m(speed, max_turn_rate_rad_s)
    heading = command.heading_enu_rad
    east, north = link.position_enu_m[0], link.position_enu_m[1]
    ahead = [east + distance * math.cos(heading), north + distance * math.sin(heading), command.altitude_m]
    lat, lon, _ = frame.to_geodetic(ahead)
    return Carrot(int(round(float(lat) * 1e7)), int(round(float(lon) * 1e7)), command.altitude_m,
                  ned_yaw_from_enu_heading(heading), int(now_s * 1000.0) & 0xFFFFFFFF)


def stream_requests(link: VehicleLink, memory: SendMemory, now_s: float, rate_hz: float
                    ) -> tuple[list[Action], SendMemory]:
    """The SET_MESSAGE_INTERVAL requests due: at once for a new link, then again at each
    :data:`STREAM_CHECK_PERIOD_S` check that finds a stream below :data:`STREAM_ARRIVAL_FRACTION` of
    ``rate_hz`` (measured since the previous check, on the clock of ``now_s``)."""
    if memory.streams_asked_s is not None and now_s - memory.streams_asked_s < STREAM_CHECK_PERIOD_S:
        return [], memory  # between two checks (every pass of the daemon's loop): nothing to build
    counts = tuple(link.arrivals[name] for name in STREAMED_TELEMETRY)
    requests: list[Action] = [MessageInterval(message_id, 1e6 / rate_hz) for message_id in STREAMED_TELEMETRY.values()]
    if memory.streams_asked_s is None:
        return requests, replace(memory, streams_asked_s=now_s, arrivals_when_asked=counts)
    elapsed = now_s - memory.streams_asked_s
    rates = tuple((now - before) / elapsed for now, before in zip(counts, memory.arrivals_when_asked))
    memory = replace(memory, streams_asked_s=now_s, arrivals_when_asked=counts, stream_rates_hz=rates)
    if min(rates) < STREAM_ARRIVAL_FRACTION * rate_hz:
        return requests, memory
    return [], memory


def due_actions(frame: LocalFrame, link: VehicleLink, memory: SendMemory, now_s: float, *,
                max_turn_rate_rad_s: float, carrot_period_s: float, link_timeout_s: float,
                stream_rate_hz: float = DEFAULT_STREAM_RATE_HZ, takeover: Takeover = Takeover()
                ) -> tuple[list[Action], SendMemory]:
    """What to send to one vehicle now, and the memory after sending it (pure).

    Nothing without a HEARTBEAT within ``link_timeout_s``. Then, in order: the
    stream-rate requests that are due (:func:`stream_requests`; none with
    ``stream_rate_hz`` 0); the hand-back request when one is due; nothing more
    without a command; for a peer that is not ArduPilot, the carrot when its
    period has elapsed (and a position is known); a mode request when the
    vehicle is not in GUIDED/OFFBOARD and the takeover guard allows it, at most
    one per ``MODE_REQUEST_PERIOD_S``; and, to an ArduPilot peer in GUIDED, the
    GUIDED_CHANGE_HEADING / _SPEED / _ALTITUDE whose value moved by more than
    0.5 degree / 0.1 m/s / 0.5 m since the last one sent.
    """
    if not link.alive(now_s, link_timeout_s):
        return [], memory
    actions: list[Action] = []
    if stream_rate_hz > 0:
        actions, memory = stream_requests(link, memory, now_s, stream_rate_hz)
    if memory.handback_due:
        actions.append(handback_request(link.autopilot, takeover.handback))
        memory = replace(memory, handback_due=False)
    command = link.command
    if command is None:
        return actions, memory
    if not link.is_ardupilot and link.position_enu_m is not None and now_s >= memory.next_carrot_s:
        actions.append(carrot_for(frame, link, command, max_turn_rate_rad_s, now_s))
        memory = replace(memory, next_carrot_s=next_due(memory.next_carrot_s, now_s, carrot_period_s))
    if not in_guided_mode(link.autopilot, link.custom_mode):
        blocked = takeover_blocked(link, takeover)
        if blocked is not None and takeover.takeoff and blocked != "no position":
            request, blocked = takeoff_action(link, memory.mode_request_s, now_s)
            if request is not None:
                actions.append(request)
                memory = replace(memory, mode_request_s=now_s)
        if blocked is not None:
            return actions, replace(memory, blocked=blocked)
        if now_s - memory.mode_request_s >= MODE_REQUEST_PERIOD_S:
            px4 = link.autopilot == mavlink.MAV_AUTOPILOT_PX4
            actions.append(ModeRequest(PX4_OFFBOARD_MAIN_MODE if px4 else GUIDED))
            memory = replace(memory, mode_request_s=now_s, blocked=None)
        return actions, memory
    if not memory.took_over or memory.blocked is not None:
        memory = replace(memory, took_over=True, blocked=None)
    if not link.is_ardupilot:
        return actions, memory
    if memory.heading_rad is None or abs(wrap_angle(command.heading_enu_rad - memory.heading_rad)) > HEADING_RESEND_RAD:
        actions.append(ChangeHeading(course_param_deg(command.heading_enu_rad),
                                     LATERAL_ACCEL_MARGIN * command.airspeed_mps * max_turn_rate_rad_s))
        memory = replace(memory, heading_rad=command.heading_enu_rad)
    if memory.airspeed_mps is None or abs(command.airspeed_mps - memory.airspeed_mps) > AIRSPEED_RESEND_MPS:
        actions.append(ChangeSpeed(command.airspeed_mps))
        memory = replace(memory, airspeed_mps=command.airspeed_mps)
    if memory.altitude_m is None or abs(command.altitude_m - memory.altitude_m) > ALTITUDE_RESEND_M:
        actions.append(ChangeAltitude(command.altitude_m))
        memory = replace(memory, altitude_m=command.altitude_m)
    return actions, memory
