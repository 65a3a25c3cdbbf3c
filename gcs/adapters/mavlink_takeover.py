"""Taking a vehicle over and giving it back: the guard on switching it to GUIDED/OFFBOARD (:class:`Takeover`), its
own take-off first when asked, and the mode it is given back in."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gcs.adapters.mavlink_link import VehicleLink
from gcs.adapters.mavlink_messages import Arm, ModeRequest
from gcs.adapters.mavlink_wire import ARDUPLANE_MODES, mavlink

__all__ = ["HANDBACK_MODES", "MODE_REQUEST_PERIOD_S", "Takeover", "takeover_blocked", "takeoff_action",
           "handback_request"]

MODE_REQUEST_PERIOD_S = 1.0
"""A mode request (GUIDED/OFFBOARD, take-off) or an arming request goes at most this often, seconds."""
HANDBACK_MODES = ("LOITER", "RTL")
_HANDBACK_ARDUPILOT = {"LOITER": ModeRequest(ARDUPLANE_MODES["LOITER"]), "RTL": ModeRequest(ARDUPLANE_MODES["RTL"])}
_HANDBACK_PX4 = {"LOITER": ModeRequest(4, 3), "RTL": ModeRequest(4, 5)}
"""PX4's AUTO (main mode 4) with sub mode LOITER (3) or RTL (5)."""
_TAKEOFF_ARDUPILOT = ModeRequest(ARDUPLANE_MODES["TAKEOFF"])
_TAKEOFF_PX4 = ModeRequest(4, 2)
"""PX4's AUTO (main mode 4) with sub mode TAKEOFF (2)."""


@dataclass(frozen=True)
class Takeover:
    """When the daemon may switch a vehicle to GUIDED/OFFBOARD, and the mode it gives it back in.

    A vehicle is taken over only when its HEARTBEAT says armed and its telemetry puts it at least
    ``min_altitude_m`` above home: the daemon never switches a plane on the ground, or one taking off.
    With ``takeoff`` it arms such a vehicle and puts it in its own take-off mode first (whose
    altitude, ArduPlane's TKOFF_ALT, must be above ``min_altitude_m``).
    """

    min_altitude_m: float = 30.0
    handback: str = "LOITER"
    takeoff: bool = False

    def __post_init__(self) -> None:
        if self.handback not in HANDBACK_MODES:
            raise ValueError(f"hand-back mode {self.handback!r}; expected one of {', '.join(HANDBACK_MODES)}")
        if not math.isfinite(self.min_altitude_m):
            raise ValueError(f"takeover altitude must be finite, got {self.min_altitude_m}")


def takeover_blocked(link: VehicleLink, takeover: Takeover) -> str | None:
    """Why the vehicle may not be switched to GUIDED now (``disarmed``, ``no position``, ``below N m``), or None."""
    if not link.armed:
        return "disarmed"
    if link.position_enu_m is None:
        return "no position"
    if link.position_enu_m[2] < takeover.min_altitude_m:
        return f"below {takeover.min_altitude_m:g} m"
    return None


def _in_takeoff_mode(link: VehicleLink) -> bool:
    """The HEARTBEAT shows the take-off mode (PX4: main mode in bits 16-23, sub mode in bits 24-31)."""
    if link.autopilot == mavlink.MAV_AUTOPILOT_PX4:
        return link.custom_mode == (_TAKEOFF_PX4.custom_mode << 16 | _TAKEOFF_PX4.sub_mode << 24)
    return link.custom_mode == _TAKEOFF_ARDUPILOT.custom_mode


def takeoff_action(link: VehicleLink, mode_request_s: float, now_s: float) -> tuple[Arm | ModeRequest | None, str]:
    """Arm a disarmed vehicle, then ask for its take-off mode, each at most once per
    :data:`MODE_REQUEST_PERIOD_S` (the last request went at ``mode_request_s``): the request due now (None when
    none is) and what the vehicle is waiting for (``arming``, ``taking off``)."""
    if link.armed and _in_takeoff_mode(link):
        return None, "taking off"
    waiting = "taking off" if link.armed else "arming"
    if now_s - mode_request_s < MODE_REQUEST_PERIOD_S:
        return None, waiting
    if not link.armed:
        return Arm(), waiting
    return (_TAKEOFF_PX4 if link.autopilot == mavlink.MAV_AUTOPILOT_PX4 else _TAKEOFF_ARDUPILOT), waiting


def handback_request(autopilot: int | None, mode: str) -> ModeRequest:
    """The DO_SET_MODE that gives a vehicle back in ``mode`` (one of :data:`HANDBACK_MODES`)."""
    table = _HANDBACK_PX4 if autopilot == mavlink.MAV_AUTOPILOT_PX4 else _HANDBACK_ARDUPILOT
    return table[mode]
