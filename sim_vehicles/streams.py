"""Telemetry stream rates of a simulated autopilot, changed by REQUEST_DATA_STREAM and SET_MESSAGE_INTERVAL.

A :class:`MessageSchedule` holds one interval per streamed message id, in
simulation time, and says which messages are due at each physics step. The
n-th sending after a rate is set is due at ``origin + n / rate`` (no drift),
the first at once; a message whose interval is None is not sent.

How each request changes the schedule follows the autopilots' sources:

* **ArduPilot** (``libraries/GCS_MAVLink/GCS_Common.cpp``):
  ``handle_request_data_stream`` sets the rate (Hz) of a whole stream group
  (``start_stop`` 0 stops it, 1 sets ``req_message_rate``, anything else is
  ignored; ``MAV_DATA_STREAM_ALL`` sets every group); no reply is sent. The
  groups and their messages are ArduPlane's ``STREAM_*_msgs`` tables
  (``ArduPlane/GCS_Mavlink.cpp``): EXTENDED_STATUS holds GPS_RAW_INT and
  POSITION_TARGET_GLOBAL_INT, POSITION holds GLOBAL_POSITION_INT, EXTRA1 holds
  ATTITUDE, EXTRA2 holds VFR_HUD. ``set_message_interval``: interval 0 resets
  the message to its default rate, -1 stops it, below 1 ms counts as 1 ms,
  above 60 s as 60 s; a message the vehicle does not stream gets
  MAV_RESULT_FAILED.
* **PX4** (``src/modules/mavlink/mavlink_receiver.cpp``): SET_MESSAGE_INTERVAL
  with a negative interval stops the message, 0 restores its default, a
  positive one sets it (unknown messages: MAV_RESULT_FAILED);
  REQUEST_DATA_STREAM is not handled by PX4's receiver at all.
"""

from __future__ import annotations

import math

from gcs.adapters.mavlink_wire import mavlink

__all__ = ["ARDUPILOT_STREAM_GROUPS", "MessageSchedule", "STREAMED_MESSAGES"]

STREAMED_MESSAGES = (
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
    mavlink.MAVLINK_MSG_ID_ATTITUDE,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
    mavlink.MAVLINK_MSG_ID_VFR_HUD,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT,
)
"""The position/attitude messages a simulated vehicle streams (HEARTBEAT and SYS_STATUS go at a fixed 1 Hz)."""

ARDUPILOT_STREAM_GROUPS: dict[int, tuple[int, ...]] = {
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: (mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
                                              mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT),
    mavlink.MAV_DATA_STREAM_POSITION: (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,),
    mavlink.MAV_DATA_STREAM_EXTRA1: (mavlink.MAVLINK_MSG_ID_ATTITUDE,),
    mavlink.MAV_DATA_STREAM_EXTRA2: (mavlink.MAVLINK_MSG_ID_VFR_HUD,),
}
"""ArduPlane's stream groups (SRn_EXT_STAT, SRn_POSITION, SRn_EXTRA1, SRn_EXTRA2), restricted to what we stream."""

_EPSILON_S = 1e-9


class MessageSchedule:
    """Per-message intervals (simulation seconds) and which messages are due.

    Parameters
    ----------
    default_rates_hz : dict of message id -> Hz
        The rate each streamed message starts at and returns to on a reset; 0 for off.
    """

    def __init__(self, default_rates_hz: dict[int, float]) -> None:
        self.defaults_hz = dict(default_rates_hz)
        self._period_s: dict[int, float | None] = {}
        self._origin_s: dict[int, float] = {}
        self._count: dict[int, int] = {}
        for message_id, rate in self.defaults_hz.items():
            self.set_rate(message_id, rate, 0.0)

    def knows(self, message_id: int) -> bool:
        """Whether this vehicle streams ``message_id`` at all."""
        return message_id in self.defaults_hz

    def rate_hz(self, message_id: int) -> float:
        """The current rate of a message (0 when off)."""
        period = self._period_s.get(message_id)
        return 0.0 if period is None else 1.0 / period

    def set_rate(self, message_id: int, rate_hz: float, now_s: float) -> None:
        """Send ``message_id`` at ``rate_hz`` from ``now_s`` on (the first at once); 0 or less stops it."""
        self.set_interval(message_id, 1.0 / rate_hz if rate_hz > 0 else None, now_s)

    def set_interval(self, message_id: int, interval_s: float | None, now_s: float) -> None:
        """Send ``message_id`` every ``interval_s`` from ``now_s`` on; None stops it."""
        self._period_s[message_id] = interval_s
        self._origin_s[message_id] = now_s
        self._count[message_id] = 0

    def reset(self, message_id: int, now_s: float) -> None:
        """Back to the default rate."""
        self.set_rate(message_id, self.defaults_hz[message_id], now_s)

    def due(self, now_s: float) -> list[int]:
        """The messages due at ``now_s``, each at most once per call."""
        out = []
        for message_id, period in self._period_s.items():
            if period is None:
                continue
            since = now_s - self._origin_s[message_id] + _EPSILON_S
            if since >= self._count[message_id] * period:
                self._count[message_id] = math.floor(since / period) + 1
                out.append(message_id)
        return out

    def skip_to(self, now_s: float) -> None:
        """Nothing is due for the time before ``now_s`` (a run joined late): the next sendings fall on the grid
        at or after ``now_s``."""
        for message_id, period in self._period_s.items():
            if period is not None:
                self._count[message_id] = math.ceil((now_s - self._origin_s[message_id]) / period - _EPSILON_S)

    # ------------------------------------------------------------- requests

    def ardupilot_data_stream(self, stream_id: int, rate_hz: int, start_stop: int, now_s: float) -> None:
        """REQUEST_DATA_STREAM as ArduPilot's ``handle_request_data_stream`` treats it."""
        if start_stop not in (0, 1):
            return
        rate = float(rate_hz) if start_stop == 1 else 0.0
        if stream_id == mavlink.MAV_DATA_STREAM_ALL:
            groups = list(ARDUPILOT_STREAM_GROUPS.values())
        elif stream_id in ARDUPILOT_STREAM_GROUPS:
            groups = [ARDUPILOT_STREAM_GROUPS[stream_id]]
        else:
            return
        for group in groups:
            for message_id in group:
                if self.knows(message_id):
                    self.set_rate(message_id, rate, now_s)

    def ardupilot_message_interval(self, message_id: int, interval_us: float, now_s: float) -> int:
        """SET_MESSAGE_INTERVAL as ArduPilot's ``set_message_interval`` treats it; returns the MAV_RESULT."""
        if not self.knows(message_id):
            return mavlink.MAV_RESULT_FAILED
        interval = int(interval_us)
        if interval == 0:
            self.reset(message_id, now_s)
        elif interval == -1:
            self.set_interval(message_id, None, now_s)
        else:
            self.set_interval(message_id, min(max(interval, 1000), 60_000_000) * 1e-6, now_s)
        return mavlink.MAV_RESULT_ACCEPTED

    def px4_message_interval(self, message_id: int, interval_us: float, now_s: float) -> int:
        """SET_MESSAGE_INTERVAL as PX4's ``MavlinkReceiver::set_message_interval`` treats it; returns the MAV_RESULT."""
        if not self.knows(message_id):
            return mavlink.MAV_RESULT_FAILED
        if interval_us < 0:
            self.set_interval(message_id, None, now_s)
        elif interval_us == 0:
            self.reset(message_id, now_s)
        else:
            self.set_interval(message_id, interval_us * 1e-6, now_s)
        return mavlink.MAV_RESULT_ACCEPTED
