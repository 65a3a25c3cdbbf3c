"""The daemon's steering: each vehicle commanded along the path the engine planned for it, from its latest
MAVLink telemetry, :data:`~gcs.engine.memory.STEER_RATE_HZ` times a second of vehicle time.

The steering is the path follower's (:mod:`gcs.core.steering`), encoded with the lead that makes the course loop of
the vehicle's autopilot (the one its scenario names) turn at the rate wanted: the course
an ArduPilot peer is told, and the direction of a PX4 peer's carrot. Following the path from where the vehicle
is *now* absorbs the delay between the reports a plan was made from and the moment it
is flown. Without telemetry the plan's course one step on is commanded. The engine measures each
command's age (:class:`~gcs.engine.memory.CommandAges`), without MAVLink too (``gcs-bench daemon``):
the age of the plan a vehicle would be steered along.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from gcs.adapters.mavlink_io import MavlinkCommander
from gcs.adapters.mavlink_link import HeadingCommand, steering_command
from gcs.core.steering import SAMPLES_PER_STEP, CourseLoop, PlannedPath
from gcs.engine.memory import STEER_RATE_HZ

__all__ = ["steer_along_paths"]


def steer_along_paths(commander: MavlinkCommander, steered: Sequence[tuple[str, PlannedPath]],
                      course_loops: Mapping[str, CourseLoop], now: float, data_rate: float) -> None:
    """Command each vehicle of ``steered`` along its path at loop time ``now`` (``data_rate``: vehicle seconds a loop
    second, for the age of its position)."""
    period = 1.0 / STEER_RATE_HZ
    for vehicle_id, path in steered:
        link = commander.link(vehicle_id)
        latency = link.position_age_s(now) * data_rate
        command = steering_command(link, path, course_loops[vehicle_id], period, latency)
        if command is None:
            fallback = float(path.courses[min(SAMPLES_PER_STEP, len(path.courses) - 1)])
            command = HeadingCommand(fallback, path.altitude_m, path.airspeed_mps)
        commander.command(vehicle_id, command)
