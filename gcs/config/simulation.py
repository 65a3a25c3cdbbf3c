"""The ``[simulation]`` table: how the simulated vehicles, their sensors and their autopilots behave.

Only ``sim_vehicles`` and the benchmarks that simulate read it; the ground station never does.
"""

from __future__ import annotations

from typing import Annotated

import msgspec

from gcs.config.base import Config as _Config
from gcs.config.base import Identifier, NonNegative, Point2, Positive

__all__ = ["AUTOPILOT_PERSONALITIES", "AirframeConfig", "GpsConfig", "GpsDeniedZone", "InsConfig", "SimulationConfig"]

AUTOPILOT_PERSONALITIES = ("ideal", "arduplane", "px4")
"""How a simulated vehicle's autopilot behaves (``sim_vehicles.personalities``)."""


class AirframeConfig(_Config, frozen=True):
    """Autopilot-driven fixed-wing response used by the simulated vehicles (``sim_vehicles``).

    Bank follows its command as a first-order lag of ``roll_time_constant_s``;
    the turn rate is ``g tan(bank) / airspeed``, capped by ``max_bank_rad`` and
    by the vehicle's ``max_turn_rate_rad_s``. Airspeed follows its command as a
    first-order lag; altitude is held with a climb rate of at most ``max_climb_rate_mps``.
    """

    max_bank_rad: Annotated[float, msgspec.Meta(gt=0.0, lt=1.5)] = 0.6
    roll_time_constant_s: Positive = 0.5
    heading_gain_per_s: Positive = 1.0
    """Turn rate commanded per radian of course error (then capped), 1/s."""
    airspeed_time_constant_s: Positive = 3.0
    altitude_time_constant_s: Positive = 5.0
    max_climb_rate_mps: Positive = 5.0
    min_airspeed_mps: Positive = 12.0
    max_airspeed_mps: Positive = 40.0
    loiter_radius_m: Positive = 150.0


class GpsConfig(_Config, frozen=True):
    """Simulated GPS: white noise plus a slowly varying (first-order Gauss-Markov) bias, per axis."""

    horizontal_std_m: Positive = 2.0
    vertical_std_m: Positive = 3.0
    bias_std_m: NonNegative = 1.0
    bias_time_constant_s: Positive = 300.0
    satellites: Annotated[int, msgspec.Meta(ge=0, le=255)] = 12


class InsConfig(_Config, frozen=True):
    """Simulated INS/odometry increments (feng2019 eq. 1): distance and heading change per interval.

    Distance gets a scale-factor error and white noise; the heading change gets a
    constant gyro drift and white noise, so dead reckoning drifts as in the paper.
    """

    distance_scale_error: Annotated[float, msgspec.Meta(ge=-0.5, le=0.5)] = 0.01
    distance_std_m: NonNegative = 0.5
    heading_drift_rad_s: Annotated[float, msgspec.Meta(ge=-1.0, le=1.0)] = 0.0005
    heading_std_rad: NonNegative = 0.002


class GpsDeniedZone(_Config, frozen=True):
    """A horizontal polygon (ENU metres) inside which simulated vehicles have no GPS fix."""

    name: Identifier
    polygon_enu_m: Annotated[list[Point2], msgspec.Meta(min_length=3)]


class SimulationConfig(_Config, frozen=True):
    """How ``sim-vehicles`` simulates the scenario: airframe, navigation sensors, wind and rates.

    Rates are in simulation time; ``sim-vehicles run --rate R`` scales them all.
    """

    physics_step_s: Annotated[float, msgspec.Meta(gt=0.0, le=0.5)] = 0.05
    report_rate_hz: Annotated[float, msgspec.Meta(gt=0.0, le=1000.0)] = 1.0
    """SensorReport rate per vehicle (the paper's 1 s step)."""
    nav_rate_hz: Annotated[float, msgspec.Meta(gt=0.0, le=1000.0)] = 5.0
    """NavReport rate per vehicle."""
    telemetry_rate_hz: Annotated[float, msgspec.Meta(gt=0.0, le=50.0)] = 4.0
    """MAVLink position/attitude stream rate of the ``ideal`` autopilot (HEARTBEAT and SYS_STATUS are 1 Hz)."""
    autopilot: str = "ideal"
    """Autopilot personality of every simulated vehicle: one of ``AUTOPILOT_PERSONALITIES``."""
    start_on_ground: bool = False
    """The vehicles start disarmed, parked at their start points on the ground, until a take-off."""
    wind_enu_mps: tuple[Annotated[float, msgspec.Meta(ge=-50.0, le=50.0)], Annotated[float, msgspec.Meta(ge=-50.0, le=50.0)]] = (0.0, 0.0)
    airframe: AirframeConfig = AirframeConfig()
    gps: GpsConfig = GpsConfig()
    ins: InsConfig = InsConfig()
