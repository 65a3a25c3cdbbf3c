"""Wire messages exchanged over Zenoh, as frozen msgspec Structs.

Frames, units and time
----------------------
- Positions are metres in a local **ENU** frame (x east, y north, z up) about the
  scenario's geodetic origin.
- **Azimuth** is ``atan2(dy, dx)`` of target minus vehicle: from east, counter-clockwise,
  radians in (-pi, pi]; headings likewise. The wire also accepts exactly -pi (what
  ``atan2(-0.0, -1.0)`` returns), meaning the same direction as pi.
- **Elevation** is ``atan2(dz, horizontal distance)``, in [-pi/2, pi/2], negative when
  the target is below the vehicle. **Range** is the 3-D distance.
- ``stamp_ns`` is integer nanoseconds when the measurement was taken (simulation or
  vehicle time), never the arrival time; estimators order data by it.
- Field names carry their units (``_m``, ``_rad``, ``_mps``, ``_deg``, ``_ns``, ``_s``).

Validation
----------
msgspec checks types and ranges (:mod:`protocols.fields`) when decoding, naming the
field's path. Cross-field rules live in ``__post_init__`` (run on construction and on
decoding) and raise :class:`~protocols.errors.ProtocolError` naming the field. msgspec
never checks ranges in ``__init__``; :func:`protocols.codec.encode` checks them, and
finiteness, before anything is sent.

Versions
--------
Every message type has a class-level ``VERSION`` (a ``ClassVar``, ignored by msgspec);
it travels in the Zenoh encoding ``application/json;gcs.<TypeName>/<VERSION>``.
``SensorReport`` and its ``Measurement`` live in :mod:`protocols.sensor_report`, a vehicle's
scenario announcement in :mod:`protocols.vehicle_scenario`; the earlier versions still read are
in :mod:`protocols.legacy`.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Annotated

from msgspec import Meta

from protocols.base import Message
from protocols.errors import ProtocolError
from protocols.fields import (
    COVARIANCE_SYMMETRY_RTOL,
    AirspeedMps,
    AltitudeM,
    AngleIncrementRad,
    AngleRad,
    CovarianceEntry,
    DistanceM,
    DurationS,
    Ident,
    LatDeg,
    LonDeg,
    PositionM,
    RateRadS,
    Seq,
    StampNs,
    StateValue,
    StdM,
    VelocityMps,
    check_covariance,
)
from protocols.federation import FederatedTrack, MemberTracks
from protocols.sensor_report import MAX_DETECTIONS, Measurement, SensorReport
from protocols.status import DaemonStatus, TrackSummary, VehicleStatus
from protocols.vehicle_scenario import VehicleScenario

__all__ = [
    "COVARIANCE_SYMMETRY_RTOL",
    "MAX_DETECTIONS",
    "MAX_STATE_DIM",
    "TRACK_MODEL_DIMS",
    "DaemonStatus",
    "FederatedTrack",
    "GpsFix",
    "InsIncrement",
    "Measurement",
    "MemberTracks",
    "Message",
    "MESSAGE_TYPES",
    "NavReport",
    "PlanCommand",
    "PredictedPoint",
    "SensorReport",
    "TargetTruth",
    "TrackEstimate",
    "TrackSummary",
    "VehicleScenario",
    "VehicleStatus",
]

#: Largest state dimension a TrackEstimate may carry.
MAX_STATE_DIM = 16
#: State dimension of the known target models; other model names are accepted with
#: any dimension up to MAX_STATE_DIM.
TRACK_MODEL_DIMS: Mapping[str, int] = MappingProxyType({"cv2d": 4, "ca2d": 6})


class GpsFix(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A GNSS position fix, as in MAVLink ``GPS_RAW_INT`` / ``GLOBAL_POSITION_INT``.

    Attributes
    ----------
    lat_deg, lon_deg : float
        WGS84 latitude in [-90, 90] and longitude in [-180, 180], degrees.
    alt_m : float
        Altitude above mean sea level (MSL, as ``GLOBAL_POSITION_INT.alt``), metres.
    fix_type : int
        MAVLink ``GPS_FIX_TYPE``: 0 no GPS, 1 no fix, 2 2D, 3 3D, 4 DGPS,
        5 RTK float, 6 RTK fixed, 7 static, 8 PPP.
    h_acc_m, v_acc_m : float
        Horizontal and vertical 1-sigma accuracy (> 0), metres.
    satellites : int or None
        Satellites used, if known.
    """

    lat_deg: LatDeg
    lon_deg: LonDeg
    alt_m: AltitudeM
    fix_type: Annotated[int, Meta(ge=0, le=8)]
    h_acc_m: StdM
    v_acc_m: StdM
    satellites: Annotated[int, Meta(ge=0, le=255)] | None = None


class InsIncrement(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Dead-reckoning increments of a strapdown/odometry INS over ``dt_s``.

    Attributes
    ----------
    dt_s : float
        Integration interval (> 0), seconds, ending at the report's ``stamp_ns``.
    distance_m : float
        Distance travelled over the interval (>= 0), metres.
    heading_change_rad : float
        Heading change over the interval, counter-clockwise positive, radians.
    """

    dt_s: DurationS
    distance_m: DistanceM
    heading_change_rad: AngleIncrementRad


class NavReport(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A vehicle's own navigation data: GPS fix, INS increments, velocity, heading.

    At least one of ``gps``, ``ins`` and ``velocity_enu_mps`` is present.

    Attributes
    ----------
    vehicle_id, seq, stamp_ns
        Publisher, its sequence number and the measurement time (ns).
    gps : GpsFix or None
    ins : InsIncrement or None
    velocity_enu_mps : tuple of 3 float or None
        Ground velocity in ENU, m/s.
    turn_rate_rad_s : float or None
        Heading rate, counter-clockwise positive, rad/s.
    heading_rad : float or None
        Heading in ENU (from east, counter-clockwise), radians.
    """

    vehicle_id: Ident
    seq: Seq
    stamp_ns: StampNs
    gps: GpsFix | None = None
    ins: InsIncrement | None = None
    velocity_enu_mps: tuple[VelocityMps, VelocityMps, VelocityMps] | None = None
    turn_rate_rad_s: RateRadS | None = None
    heading_rad: AngleRad | None = None

    def __post_init__(self) -> None:
        if self.gps is None and self.ins is None and self.velocity_enu_mps is None:
            raise ProtocolError(
                "a nav report needs at least one of gps, ins, velocity_enu_mps",
                field="$.gps",
            )


class PredictedPoint(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Predicted target position at a future time (the k+1..k+n prediction).

    Attributes
    ----------
    stamp_ns : int
        Time the prediction is for.
    position_enu_m : tuple of 2 float
        Predicted (x, y), metres ENU.
    position_cov_m2 : tuple of 4 float
        Row-major 2x2 covariance of (x, y), m^2: symmetric, diagonal >= 0.
    """

    stamp_ns: StampNs
    position_enu_m: tuple[PositionM, PositionM]
    position_cov_m2: tuple[CovarianceEntry, CovarianceEntry, CovarianceEntry, CovarianceEntry]

    def __post_init__(self) -> None:
        check_covariance(self.position_cov_m2, 2, "position_cov_m2")


class TrackEstimate(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The fused estimate of one target, with optional predictions.

    Attributes
    ----------
    target_id, seq, stamp_ns
        Target, the daemon's sequence number and the time the estimate is valid for.
    model : str
        State layout: ``"cv2d"`` is [x, y, vx, vy]; ``"ca2d"`` is
        [x, y, vx, vy, ax, ay] (ENU, SI units). For these, ``len(state)`` is checked.
    state : tuple of float
        State vector, length n (1..MAX_STATE_DIM).
    covariance : tuple of float
        Row-major n x n covariance: length n*n, symmetric within
        COVARIANCE_SYMMETRY_RTOL, diagonal >= 0.
    contributing_vehicles : tuple of str
        Vehicles whose reports went into this estimate.
    prediction : tuple of PredictedPoint
        Predicted positions at future stamps (may be empty).
    """

    target_id: Ident
    seq: Seq
    stamp_ns: StampNs
    model: Ident
    state: Annotated[tuple[StateValue, ...], Meta(min_length=1, max_length=MAX_STATE_DIM)]
    covariance: Annotated[
        tuple[CovarianceEntry, ...], Meta(min_length=1, max_length=MAX_STATE_DIM**2)
    ]
    contributing_vehicles: Annotated[tuple[Ident, ...], Meta(max_length=256)]
    prediction: Annotated[tuple[PredictedPoint, ...], Meta(max_length=64)] = ()

    def __post_init__(self) -> None:
        n = len(self.state)
        expected = TRACK_MODEL_DIMS.get(self.model)
        if expected is not None and n != expected:
            raise ProtocolError(
                f"state has {n} entries but model {self.model!r} needs {expected}",
                field="$.state",
            )
        check_covariance(self.covariance, n, "covariance")


class PlanCommand(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The planner's command for one vehicle.

    Attributes
    ----------
    vehicle_id, seq, stamp_ns
        Commanded vehicle, the daemon's sequence number and the planning time.
    heading_rad : float
        Commanded heading, ENU from east counter-clockwise, radians.
    turn_rate_rad_s : float
        Commanded turn rate, counter-clockwise positive, rad/s.
    airspeed_mps : float
        Commanded airspeed (> 0), m/s.
    altitude_m : float
        Commanded altitude relative to home, metres.
    planned_path_enu_m : tuple of (x, y)
        The planned horizontal path (ENU, m), for display; may be empty.
    planner : str
        Which planner produced the command (e.g. ``"ga-rhc"``).
    """

    vehicle_id: Ident
    seq: Seq
    stamp_ns: StampNs
    heading_rad: AngleRad
    turn_rate_rad_s: RateRadS
    airspeed_mps: AirspeedMps
    altitude_m: AltitudeM
    planned_path_enu_m: Annotated[tuple[tuple[PositionM, PositionM], ...], Meta(max_length=1024)] = ()
    planner: Ident


class TargetTruth(Message, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Ground truth of a simulated target, published by ``sim-vehicles`` only.

    Lets the daemon, the live page and ``gcs demo`` score the track against the
    truth; nothing in the estimator reads it.

    Attributes
    ----------
    target_id, seq, stamp_ns
        Target, the simulator's sequence number and the simulation time.
    position_enu_m : tuple of 2 float
        True (x, y), metres ENU.
    velocity_enu_mps : tuple of 2 float
        True ground velocity, m/s ENU.
    """

    target_id: Ident
    seq: Seq
    stamp_ns: StampNs
    position_enu_m: tuple[PositionM, PositionM]
    velocity_enu_mps: tuple[VelocityMps, VelocityMps]


#: Every message type the codec knows, top-level and nested.
MESSAGE_TYPES: tuple[type[Message], ...] = (
    SensorReport, Measurement, GpsFix, InsIncrement, NavReport, PredictedPoint,
    TrackEstimate, PlanCommand, VehicleStatus, TrackSummary, DaemonStatus, TargetTruth, VehicleScenario,
    FederatedTrack, MemberTracks,
)
