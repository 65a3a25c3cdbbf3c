"""The real ArduPlane's course loop, identified from course steps flown in SITL (``gcs-bench autopilots --identify
--sitl PATH``).

One ArduPlane takes off, is switched to GUIDED at the scenario's airspeed and an altitude of
:data:`ALTITUDE_M`, and is given course steps with GUIDED_CHANGE_HEADING, each from straight and level
flight, with the lateral acceleration limit the daemon sends (``margin V omega_max``,
:data:`gcs.adapters.mavlink_commands.LATERAL_ACCEL_MARGIN`), as :func:`benchmarks.autopilots.step_response`
gives them to a personality: :data:`SMALL_STEP_DEG` to the
left and to the right, then :data:`LARGE_STEP_DEG` both ways. The course is read from
GLOBAL_POSITION_INT at 20 Hz on SITL's clock, its rate taken by central differences and averaged over
the two directions; then turns held with a constant lead (:data:`benchmarks.autopilots.HELD_LEADS_DEG`,
the course asked that far ahead of the plane's, sent again four times a second as the daemon's steering
sends it), both ways. The loop is fitted as a personality's is (:func:`benchmarks.autopilots.fit_course_loop`).

Run inside a private network namespace (:mod:`benchmarks.sitl.namespace`); the result is written as JSON.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from benchmarks.autopilots import HELD_LEADS_DEG, LARGE_STEP_DEG, SMALL_STEP_DEG, STEER_RATE_HZ, held_rate
from benchmarks.sitl.arduplane import ArduPlaneSitl, defaults_beside, find_binary
from benchmarks.sitl.pilot import Pilot, Sample
from gcs.adapters.mavlink_commands import LATERAL_ACCEL_MARGIN
from gcs.adapters.mavlink_wire import mavlink
from gcs.core.geometry import wrap_angle

__all__ = ["ALTITUDE_M", "fly_steps", "main", "step_rates"]

log = logging.getLogger(__name__)

ALTITUDE_M = 150.0
STEP_S = 20.0
"""Seconds recorded after each step."""
SETTLE_S = 12.0
"""Seconds of straight flight before each step."""
RATE_HZ = 20.0
HOME = (28.2308274, 113.0022259, 50.0, 45.0)


def step_rates(samples: list[Sample], start_s: float, step_rad: float, seconds: float = STEP_S,
               dt: float = 0.05) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Times after the step (s, every ``dt``) and the turn rate toward it (rad/s: positive turns toward the new
    course), from the samples from ``start_s`` on (SITL time)."""
    times = np.array([s.time_s for s in samples])
    courses = np.unwrap(np.array([s.course_rad for s in samples]))
    keep = (times >= start_s - 1.0) & (times <= start_s + seconds + 1.0)
    times, courses = times[keep], courses[keep]
    rates = np.gradient(courses, times) * math.copysign(1.0, step_rad)
    grid = np.arange(dt, seconds + dt / 2, dt)
    return grid, np.interp(start_s + grid, times, rates)


def fly_steps(pilot: Pilot, airspeed_mps: float, max_turn_rate_rad_s: float) -> dict:
    """Fly the steps (module docstring); the rates after each, by step size, and the bank angles seen."""
    accel = LATERAL_ACCEL_MARGIN * airspeed_mps * max_turn_rate_rad_s
    pilot.wait_for("GUIDED mode", lambda: pilot.mode == "GUIDED", 10.0, every_s=1.0,
                   action=lambda: pilot.set_mode("GUIDED"))
    pilot.guided_speed(airspeed_mps)
    pilot.guided_altitude(ALTITUDE_M)
    pilot.guided_course(pilot.course_rad, accel)
    pilot.wait_for(f"{ALTITUDE_M:g} m", lambda: abs(pilot.altitude_m - ALTITUDE_M) < 5.0, 120.0)
    pilot.recording = True
    steps: dict[str, list] = {}
    for step_deg in (SMALL_STEP_DEG, -SMALL_STEP_DEG, LARGE_STEP_DEG, -LARGE_STEP_DEG):
        pilot.guided_course(pilot.course_rad, accel)  # straight and level first
        pilot.pump(SETTLE_S)
        start = pilot.boot_s
        step = math.radians(step_deg)
        pilot.guided_course(wrap_angle(pilot.course_rad + step), accel)
        pilot.pump(STEP_S + 1.5)
        times, rates = step_rates(pilot.samples, start, step)
        steps.setdefault(str(abs(step_deg)), []).append(rates.tolist())
    held: dict[str, list[float]] = {}
    for lead_deg in HELD_LEADS_DEG:
        for sign in (1.0, -1.0):
            pilot.guided_course(pilot.course_rad, accel)
            pilot.pump(SETTLE_S)
            start = pilot.boot_s
            lead = sign * math.radians(lead_deg)
            for _ in range(int(STEP_S * STEER_RATE_HZ)):  # the lead held, sent again as the daemon sends it
                pilot.guided_course(wrap_angle(pilot.course_rad + lead), accel)
                pilot.pump(1.0 / STEER_RATE_HZ)
            pilot.pump(1.5)
            held_times, rates = step_rates(pilot.samples, start, lead)
            held.setdefault(str(lead_deg), []).append(held_rate(rates, held_times))
    rolls = np.degrees(np.abs([s.roll_rad for s in pilot.samples]))
    speeds = np.array([s.speed_mps for s in pilot.samples])
    return {"times_s": times.tolist(), "rates_rad_s": steps, "held_rad_s": held, "bank_deg_max": float(rolls.max()),
            "bank_deg_p90": float(np.percentile(rolls, 90)), "ground_speed_mps_median": float(np.median(speeds)),
            "airspeed_mps": airspeed_mps, "max_turn_rate_rad_s": max_turn_rate_rad_s,
            "accel_limit_mps2": accel}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sitl.identify", description=__doc__.splitlines()[0])
    parser.add_argument("--sitl", required=True)
    parser.add_argument("--airspeed", type=float, default=25.0)
    parser.add_argument("--max-turn-rate", type=float, default=0.2)
    parser.add_argument("--json", type=Path, required=True)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    binary = find_binary(args.sitl)
    sitl = ArduPlaneSitl(binary, 0, 1, HOME, defaults=defaults_beside(binary)).start()
    pilot = Pilot(sitl.connection(0), 1)
    try:
        pilot.wait_for("a heartbeat", lambda: "HEARTBEAT" in pilot.latest, 60.0)
        for message_id in (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mavlink.MAVLINK_MSG_ID_ATTITUDE):
            pilot.request_rate(message_id, RATE_HZ)
        pilot.take_off(40.0)
        result = fly_steps(pilot, args.airspeed, args.max_turn_rate)
    finally:
        pilot.close()
        sitl.stop()
    args.json.write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
